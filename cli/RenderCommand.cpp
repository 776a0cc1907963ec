// `voxbrick render STORE -o out.png`: one frame, headless, with its statistics.
#include <cstdio>
#include <fstream>
#include <sstream>

#include "brickstore/BrickCache.h"
#include "brickstore/BrickStore.h"
#include "brickstore/Errors.h"
#include "cli/Commands.h"
#include "cli/SceneOptions.h"
#include "render/GlContext.h"
#include "render/RenderErrors.h"
#include "render/Scene.h"
#include "render/VolumeRenderer.h"

namespace voxbrick::cli {
namespace {

struct RenderArgs {
  SceneArgs scene;
  std::string store, output, statsPath;
  std::string backend = "auto", atlasFormat = "float";
  bool quiet = false;
  int64_t gpuBudgetMB = 1024, hostBudgetMB = 1024;
};

void runRender(const RenderArgs& a, const CLI::App& cmd) {
  const render::Scene scene = buildScene(a.scene, cmd);
  auto store = store::BrickStore::open(a.store);
  auto cache = std::make_shared<store::BrickCache>(store, size_t(a.hostBudgetMB) << 20, 2);
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
  addSceneOptions(cmd, args->scene);
  cmd->add_option("--backend", args->backend, "auto, egl or osmesa")->capture_default_str();
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
