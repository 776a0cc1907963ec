// `voxbrick render STORE -o out.png`: one frame, headless, with its statistics.
#include <cstdio>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "brickstore/BrickCache.h"
#include "brickstore/BrickStore.h"
#include "brickstore/Errors.h"
#include "cli/Commands.h"
#include "render/GlContext.h"
#include "render/ReferenceRenderer.h"
#include "render/RenderErrors.h"
#include "render/Scene.h"
#include "render/VolumeRenderer.h"

namespace voxbrick::cli {
namespace {

struct RenderArgs {
  std::string store, output, statsPath, sceneFile, orbit, eye, center, up, size, tf, background, window;
  std::string backend = "auto", slicer, atlasFormat = "float", analytic;
  double fov = 0, step = 0, referenceStep = 0.125;
  bool ortho = false, noSkip = false, noCull = false, shading = false, quiet = false;
  int64_t gpuBudgetMB = 1024, hostBudgetMB = 1024;
};

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw render::RenderInputError(path + ": cannot read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

glm::dvec3 triple(const std::string& text, const std::string& option) {
  double v[3];
  parseTriple(text, option, v);
  return {v[0], v[1], v[2]};
}

/// The scene: --scene first, then every option given on the command line on top of it.
render::Scene buildScene(const RenderArgs& a, const CLI::App& cmd) {
  render::Scene s = a.sceneFile.empty() ? render::Scene{} : render::Scene::fromJson(readText(a.sceneFile), a.sceneFile);
  if (!a.orbit.empty()) {
    const glm::dvec3 o = triple(a.orbit, "--orbit");
    s.camera.orbit = true;
    s.camera.azimuth = o.x, s.camera.elevation = o.y, s.camera.distance = o.z;
  }
  if (!a.eye.empty()) {
    s.camera.orbit = false;
    s.camera.eye = triple(a.eye, "--eye");
    s.camera.center = a.center.empty() ? glm::dvec3(0) : triple(a.center, "--center");
    s.camera.up = a.up.empty() ? glm::dvec3(0, 1, 0) : triple(a.up, "--up");
  }
  if (cmd.count("--fov")) s.camera.fovY = a.fov;
  if (a.ortho) s.camera.orthographic = true;
  if (!a.size.empty()) {
    int w = 0, h = 0;
    char extra = 0;
    if (std::sscanf(a.size.c_str(), "%dx%d%c", &w, &h, &extra) != 2)
      throw render::RenderInputError("--size '" + a.size + "': expected WIDTHxHEIGHT");
    s.width = w, s.height = h;
  }
  if (!a.tf.empty()) {
    s.transferFunction = render::TransferFunction::load(a.tf);
    s.transferFunctionName = a.tf;
  }
  if (cmd.count("--step")) s.step = a.step;
  if (!a.background.empty()) s.background = triple(a.background, "--background");
  if (!a.window.empty()) {
    double lo = 0, hi = 0;
    char extra = 0;
    if (std::sscanf(a.window.c_str(), "%lf,%lf%c", &lo, &hi, &extra) != 2)
      throw render::RenderInputError("--window '" + a.window + "': expected LO,HI");
    s.window = std::array<double, 2>{lo, hi};
  }
  if (a.noSkip) s.skipEmpty = false;
  if (a.noCull) s.cullFrustum = false;
  if (a.shading) s.shading = true;
  if (!a.slicer.empty()) s.slicer = a.slicer == "cpu" ? render::Slicer::Cpu : render::Slicer::Vertex;
  s.validate();
  return s;
}

/// The CPU reference: slow on purpose, double precision, the same store and scene.
void runReference(const RenderArgs& a, const render::Scene& scene, std::shared_ptr<store::BrickCache> cache) {
  render::ReferenceOptions options;
  options.step = a.referenceStep;
  if (!a.analytic.empty()) options.analytic = render::analyticFieldFor(cache->store()->meta(), a.analytic);
  render::ReferenceRenderer renderer(std::move(cache));
  render::ReferenceStats stats;
  const render::ImageF image = renderer.render(scene, options, &stats);
  render::writePng(a.output, render::toImage8(image));
  if (!a.statsPath.empty()) {
    std::ofstream out(a.statsPath);
    out << nlohmann::json{{"rays", stats.rays}, {"samples", stats.samples}, {"bricks_skipped", stats.bricksSkipped},
                          {"ms", stats.ms}}.dump(2) << "\n";
    if (!out) throw render::RenderError("cannot write " + a.statsPath);
  }
  std::printf("render: wrote %s (%dx%d) with the reference (%s, step %g voxels): %lld rays, %lld samples, %.1f ms\n",
              a.output.c_str(), scene.width, scene.height, options.analytic ? "analytic field" : "trilinear grid",
              options.step, (long long)stats.rays, (long long)stats.samples, stats.ms);
}

void runRender(const RenderArgs& a, const CLI::App& cmd) {
  const render::Scene scene = buildScene(a, cmd);
  auto store = store::BrickStore::open(a.store);
  auto cache = std::make_shared<store::BrickCache>(store, size_t(a.hostBudgetMB) << 20, 2);
  if (a.backend == "reference") return runReference(a, scene, std::move(cache));
  if (!a.analytic.empty()) throw render::RenderInputError("--analytic needs --backend reference");
  auto context = render::createContext(render::parseBackend(a.backend));
  if (!a.quiet) std::fprintf(stderr, "render: %s\n", context->describe().c_str());
  render::VolumeRenderer renderer(*context, cache, size_t(a.gpuBudgetMB) << 20,
                                  render::parseAtlasFormat(a.atlasFormat));
  render::FrameStats stats;
  const render::ImageF image = renderer.render(scene, &stats);
  render::writePng(a.output, render::toImage8(image));
  if (!a.statsPath.empty()) {
    std::ofstream out(a.statsPath);
    out << stats.toJson() << "\n";
    if (!out) throw render::RenderError("cannot write " + a.statsPath);
  }
  std::printf("render: wrote %s (%dx%d): %lld bricks drawn, %lld skipped empty, %lld culled, %lld paged in, "
              "%lld evicted, %lld batches, %.1f ms (paging %.1f, slicing %.1f, drawing %.1f, readback %.1f)\n",
              a.output.c_str(), scene.width, scene.height, (long long)stats.bricksDrawn,
              (long long)stats.bricksSkippedEmpty, (long long)stats.bricksCulled, (long long)stats.bricksPagedIn,
              (long long)stats.bricksEvicted, (long long)stats.batches, stats.msTotal, stats.msPaging,
              stats.msSlicing, stats.msDrawing, stats.msReadback);
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand("render", "Render one frame of a store to a PNG, headless");
  cmd->add_option("store", args->store, "store directory")->required();
  cmd->add_option("-o,--output", args->output, "PNG file to write")->required();
  cmd->add_option("--stats", args->statsPath, "write the frame statistics as JSON");
  cmd->add_option("--scene", args->sceneFile, "scene JSON (the options below override it)");
  cmd->add_option("--orbit", args->orbit, "AZ,EL,DIST: degrees, degrees, bounding-sphere radii (default 30,20,2.5)");
  cmd->add_option("--eye", args->eye, "x,y,z eye position (world units)");
  cmd->add_option("--center", args->center, "x,y,z look-at point (default 0,0,0)");
  cmd->add_option("--up", args->up, "x,y,z up vector (default 0,1,0)");
  cmd->add_option("--fov", args->fov, "vertical field of view in degrees (default 30)");
  cmd->add_flag("--ortho", args->ortho, "orthographic projection");
  cmd->add_option("--size", args->size, "WIDTHxHEIGHT (default 512x512)");
  cmd->add_option("--tf", args->tf, "transfer function: preset name (config/tf) or JSON file (default grayscale)");
  cmd->add_option("--step", args->step, "slice spacing in voxels (default 0.75)");
  cmd->add_option("--background", args->background, "r,g,b in [0, 1] (default 0,0,0)");
  cmd->add_option("--window", args->window, "LO,HI value window (default: the store's value range)");
  cmd->add_option("--backend", args->backend,
                  "auto, egl or osmesa (a GL context), or reference (the CPU reference renderer)")
      ->capture_default_str();
  cmd->add_option("--reference-step", args->referenceStep, "reference: integration step in voxels")
      ->capture_default_str();
  cmd->add_option("--analytic", args->analytic,
                  "reference: sample this synthetic field (NAME[,k=v...] as after synthetic:) instead of the grid");
  cmd->add_option("--slicer", args->slicer, "vertex (GPU vertex program) or cpu")
      ->check(CLI::IsMember({"vertex", "cpu"}));
  cmd->add_flag("--no-skip", args->noSkip, "draw bricks the transfer function makes empty");
  cmd->add_flag("--no-cull", args->noCull, "draw bricks outside the view frustum");
  cmd->add_flag("--shading", args->shading, "gradient (central differences) and Phong headlight shading");
  cmd->add_option("--gpu-budget", args->gpuBudgetMB, "MB of GPU memory for the brick atlas")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--host-budget", args->hostBudgetMB, "MB of host memory for decoded bricks")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  cmd->add_option("--atlas-format", args->atlasFormat,
                  "float (default: full-precision filtering), native (the store's type: less memory) or half")
      ->check(CLI::IsMember({"float", "native", "half"}));
  cmd->add_flag("-q,--quiet", args->quiet, "do not print the renderer's name");
  cmd->callback([args, cmd] { runRender(*args, *cmd); });
}

}  // namespace voxbrick::cli
