// Slicer benchmark after Zellmann & Lang (2011): the time of 270 frames, 90 rotations of 2 degrees about each of the
// x, y and z axes, for each slicer, in two modes: Blending (the normal frame) and Points (slices drawn as their
// corners, glPolygonMode GL_POINT, so that the fragment stage is almost free and the slicer's own work shows).
//
// As the paper measures: a run opens a fresh renderer (the atlas, the paper's 3D texture, loaded anew), renders the
// 270 frames once to warm up (discarded), then --passes times; its time is the mean time of a pass. The table gives
// the mean and the standard deviation over --runs runs, and the box-plane intersections (slices) per frame. Every
// run goes through all settings in turn, so that a drift of the machine's load reaches all of them alike. The volume
// is drawn in bricks with empty-space skipping (and sub-blocks, if asked), so that a frame has many boxes.
//
//   bench_slicers [--out bench/results/render] [--work bench/work] [--name slicers]
//                 [--input synthetic:blobs,n=256] [--brick 16] [--sub-block 0] [--tf hot] [--step 1]
//                 [--size 512] [--rotations 90] [--degrees 2] [--runs 10] [--passes 10]
//                 [--slicers vertex,vertex-lean,geometry,vertex-geometry,cpu] [--modes blending,points]
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "brickstore/ingest/Sources.h"
#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"
#include "render/gl/GlContext.h"
#include "render/gl/volume/VolumeRenderer.h"

namespace fs = std::filesystem;
using namespace voxbrick;

namespace {

using Clock = std::chrono::steady_clock;

struct Options {
  std::string out = "bench/results/render", work = "bench/work", name = "slicers", input = "synthetic:blobs,n=256";
  std::string tf = "hot", slicers = "vertex,vertex-lean,geometry,vertex-geometry,cpu", modes = "blending,points";
  int brick = 16, subBlock = 0, size = 512, rotations = 90, runs = 10, passes = 10;
  double step = 1, degrees = 2;
};

/// One timed setting: a slicer in a mode.
struct Setting {
  render::Slicer slicer;
  render::RenderMode mode;
  std::vector<double> runSeconds;  ///< per run: the mean time of a pass of all views
  double slicesPerFrame = 0, boxesPerFrame = 0;
};

const char* modeName(render::RenderMode mode) { return mode == render::RenderMode::Points ? "points" : "blending"; }

/// The comma-separated items of `list`.
std::vector<std::string> items(const std::string& list) {
  std::vector<std::string> out;
  for (size_t start = 0; start <= list.size();) {
    const size_t comma = std::min(list.find(',', start), list.size());
    if (comma > start) out.push_back(list.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

/// The cameras of the protocol: the volume turned by k * degrees about x, then about y, then about z
/// (k = 1..rotations each), seen from `distance` along +z with y up; turning the volume by R is turning the
/// camera by R's inverse.
std::vector<render::CameraSpec> rotations(int count, double degrees, double distance) {
  std::vector<render::CameraSpec> cameras;
  for (int axis = 0; axis < 3; ++axis) {
    glm::dvec3 about(0);
    about[axis] = 1;
    for (int k = 1; k <= count; ++k) {
      const glm::dmat4 inverse = glm::rotate(glm::dmat4(1), -glm::radians(k * degrees), about);
      render::CameraSpec c;
      c.orbit = false;
      c.eye = glm::dvec3(inverse * glm::dvec4(0, 0, distance, 1));
      c.center = glm::dvec3(0);
      c.up = glm::dvec3(inverse * glm::dvec4(0, 1, 0, 0));
      cameras.push_back(c);
    }
  }
  return cameras;
}

double mean(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / double(v.size()); }

/// Sample standard deviation (0 for fewer than two values).
double deviation(const std::vector<double>& v) {
  if (v.size() < 2) return 0;
  const double m = mean(v);
  double sum = 0;
  for (double x : v) sum += (x - m) * (x - m);
  return std::sqrt(sum / double(v.size() - 1));
}

void addOptions(CLI::App& app, Options& o) {
  app.add_option("--out", o.out, "output directory")->capture_default_str();
  app.add_option("--work", o.work, "directory for the store (made once, kept)")->capture_default_str();
  app.add_option("--name", o.name, "output files NAME.csv and NAME.md")->capture_default_str();
  app.add_option("--input", o.input, "what `voxbrick prep` takes")->capture_default_str();
  app.add_option("--tf", o.tf, "transfer function preset")->capture_default_str();
  app.add_option("--brick", o.brick, "brick size of the store")->capture_default_str();
  app.add_option("--sub-block", o.subBlock, "sub-block size (0: whole bricks)")->capture_default_str();
  app.add_option("--size", o.size, "frame side in pixels")->capture_default_str();
  app.add_option("--step", o.step, "step in voxels")->capture_default_str();
  app.add_option("--rotations", o.rotations, "turns about each axis")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--degrees", o.degrees, "degrees a turn")->capture_default_str();
  app.add_option("--runs", o.runs, "runs, each with a fresh renderer")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--passes", o.passes, "timed passes a run")->capture_default_str()->check(CLI::Range(1, 100000));
  app.add_option("--slicers", o.slicers, "slicers, comma-separated")->capture_default_str();
  app.add_option("--modes", o.modes, "blending, points, comma-separated")->capture_default_str();
}

/// Every slicer of `o.slicers` in every mode of `o.modes`; throws std::invalid_argument naming an unknown one.
std::vector<Setting> settingsOf(const Options& o) {
  std::vector<Setting> settings;
  for (const std::string& m : items(o.modes)) {
    if (m != "blending" && m != "points") throw std::invalid_argument("--modes: unknown mode '" + m + "'");
    for (const std::string& s : items(o.slicers))
      settings.push_back({render::parseSlicer(s, "--slicers"),
                          m == "points" ? render::RenderMode::Points : render::RenderMode::Normal,
                          {}});
  }
  return settings;
}

/// The store of `o.input` with bricks of `o.brick` in `o.work`, made by prep unless there.
std::shared_ptr<const store::BrickStore> openStore(const Options& o) {
  std::string storeName = o.input;
  for (char& c : storeName)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '-';
  const fs::path storePath = fs::path(o.work) / (storeName + "-b" + std::to_string(o.brick) + ".vbs");
  if (!fs::exists(storePath / "store.json")) {
    auto source = store::openSource(o.input, {});
    store::PrepOptions options;
    options.brickSize = o.brick;
    options.writeVdb = false;
    options.overwrite = true;
    store::prepStore(*source, storePath, options);
  }
  return store::BrickStore::open(storePath);
}

/// The scene of the protocol (slicing, level 0) and its cameras, the whole volume in view at every turn: its
/// bounding sphere inside the vertical field of view.
render::Scene sliceScene(const Options& o, const store::StoreMeta& meta, std::vector<render::CameraSpec>& cameras) {
  render::Scene scene;
  scene.width = scene.height = o.size;
  scene.step = o.step;
  scene.transferFunction = render::TransferFunction::load(o.tf);
  scene.transferFunctionName = o.tf;
  scene.slab = 0;  // slicing: the slicers apply only there
  scene.raycast = false;
  scene.ert = 0;
  scene.subBlock = o.subBlock;
  scene.lod = 0;
  const glm::dvec3 extent(double(meta.dims.x) * meta.spacing.x, double(meta.dims.y) * meta.spacing.y,
                          double(meta.dims.z) * meta.spacing.z);
  const double radius = 0.5 * glm::length(extent);
  const double distance = 1.05 * radius / std::sin(glm::radians(0.5 * scene.camera.fovY));
  cameras = rotations(o.rotations, o.degrees, distance);
  return scene;
}

/// One run of setting `s`: a fresh renderer and cache (the bricks paged into a new atlas, as the paper reloads its
/// texture), a warm-up pass discarded, then the timed passes; the first run also counts slices and boxes.
void timeRun(render::GlContext& context, const std::shared_ptr<const store::BrickStore>& store, render::Scene scene,
             const std::vector<render::CameraSpec>& cameras, int run, const Options& o, Setting& s) {
  auto cache = std::make_shared<store::BrickCache>(store, size_t(4) << 30, 1);
  render::VolumeRenderer renderer(context, cache, size_t(2) << 30);
  scene.slicer = s.slicer;
  const render::FrameOptions options{s.mode};
  double slices = 0, boxes = 0;
  auto pass = [&](bool tally) {
    for (const render::CameraSpec& camera : cameras) {
      scene.camera = camera;
      render::FrameStats stats;
      renderer.render(scene, &stats, options);
      if (tally) slices += double(stats.slices), boxes += double(stats.boxesDrawn);
    }
  };
  pass(false);  // warm-up: pages every brick, builds the program; discarded
  const auto start = Clock::now();
  for (int p = 0; p < o.passes; ++p) pass(run == 0 && p == 0);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count() / o.passes;
  s.runSeconds.push_back(seconds);
  if (run == 0) {
    s.slicesPerFrame = slices / double(cameras.size());
    s.boxesPerFrame = boxes / double(cameras.size());
  }
  std::printf("run %d  %-16s %-9s %8.3f s per %zu frames\n", run + 1, render::slicerName(s.slicer), modeName(s.mode),
              seconds, cameras.size());
  std::fflush(stdout);
}

void writeResults(const std::string& device, const Options& o, const std::vector<Setting>& settings, size_t frames) {
  const fs::path out = o.out;
  std::ofstream csv(out / (o.name + ".csv"));
  csv << "slicer,mode,runs,passes,frames_per_pass,mean_s,stddev_s,mean_ms_per_frame,slices_per_frame,"
         "boxes_per_frame\n";
  std::ofstream md(out / (o.name + ".md"));
  md << "Slicers after Zellmann & Lang (2011) on " << device << ": " << o.input << " in bricks of " << o.brick
     << (o.subBlock ? ", sub-blocks of " + std::to_string(o.subBlock) : std::string()) << ", transfer function " << o.tf
     << ", step " << o.step << " voxels, " << o.size << "x" << o.size << ". Seconds per pass of " << frames
     << " frames (" << o.rotations << " rotations of " << o.degrees << " degrees about x, y and z), the mean of "
     << o.passes << " passes after one discarded, averaged over " << o.runs
     << " runs, each with a fresh renderer (bricks paged anew); in parentheses the standard deviation over the runs. "
        "Blending: the normal frame; points: slices drawn as their corners (glPolygonMode GL_POINT). Slices: the "
        "planes given to the boxes of a frame (box-plane intersections; the GPU slicers get one plane more each side "
        "of a box, which their float test drops, the CPU slicer exactly the planes that cut it).\n\n"
     << "| slicer | mode | s per pass | ms per frame | slices per frame | boxes per frame |\n"
     << "|---|---|---:|---:|---:|---:|\n";
  for (const Setting& s : settings) {
    const double m = mean(s.runSeconds), sd = deviation(s.runSeconds);
    char line[512];
    std::snprintf(line, sizeof line, "%s,%s,%d,%d,%zu,%.4f,%.4f,%.3f,%.0f,%.0f\n", render::slicerName(s.slicer),
                  modeName(s.mode), o.runs, o.passes, frames, m, sd, 1e3 * m / double(frames), s.slicesPerFrame,
                  s.boxesPerFrame);
    csv << line;
    std::snprintf(line, sizeof line, "| %s | %s | %.3f (%.3f) | %.2f | %.0f | %.0f |\n", render::slicerName(s.slicer),
                  modeName(s.mode), m, sd, 1e3 * m / double(frames), s.slicesPerFrame, s.boxesPerFrame);
    md << line;
  }
  std::printf("wrote %s and %s\n", (out / (o.name + ".md")).string().c_str(),
              (out / (o.name + ".csv")).string().c_str());
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"bench_slicers: the slicers' frame time after Zellmann & Lang (2011)"};
  addOptions(app, o);
  CLI11_PARSE(app, argc, argv);
  std::vector<Setting> settings;
  try {
    settings = settingsOf(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_slicers: %s\n", e.what());
    return 2;
  }
  fs::create_directories(o.out);
  fs::create_directories(o.work);
  const auto store = openStore(o);
  auto context = render::createContext(render::Backend::Auto);
  const std::string device = context->describe();
  std::vector<render::CameraSpec> cameras;
  const render::Scene scene = sliceScene(o, store->meta(), cameras);
  std::printf(
      "bench_slicers on %s\n%s, bricks of %d, sub-blocks %d, %s, step %g, %dx%d, %zu views, %d runs of "
      "1 + %d passes\n",
      device.c_str(), o.input.c_str(), o.brick, o.subBlock, o.tf.c_str(), o.step, o.size, o.size, cameras.size(),
      o.runs, o.passes);
  // Every run goes through all settings in turn, so that a drift of the machine's load reaches all of them alike.
  for (int run = 0; run < o.runs; ++run)
    for (Setting& s : settings) timeRun(*context, store, scene, cameras, run, o, s);
  writeResults(device, o, settings, cameras.size());
  return 0;
}
