// `voxbrick orbit STORE -o frames/f%03d.png --frames N`: a turntable, N frames about the volume from one warm process;
// with --interactive MS each view is drawn as an interactive frame within MS (render/core/Interactive.h) and judged
// against its exact frame.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <future>
#include <limits>
#include <regex>
#include <thread>
#include <vector>

#include "cli/Commands.h"
#include "cli/SceneOptions.h"
#include "image/ImageFile.h"
#include "render/core/Dataset.h"
#include "render/core/Interactive.h"
#include "render/core/RenderErrors.h"
#include "render/core/Scene.h"
#include "render/engine/Datasets.h"
#include "render/engine/RenderEngine.h"

namespace voxbrick::cli {
namespace {

struct OrbitArgs {
  SceneArgs scene;
  std::string store, pattern, grid, backend = "auto";
  int brick = 32, frames = 36, jpegQuality = 90;
  int64_t time = 0, channel = 0;
  double elevation = 0;
  int64_t gpuBudgetMB = 1024, hostBudgetMB = 1024;
  double interactiveMs = 0;  ///< --interactive: each view drawn as an interactive frame with this budget; 0: exact
  bool quiet = false;
};

/// The file of frame `index`: the pattern holds one printf integer conversion (%d, %03d, ...) and no other '%'.
std::string framePath(const std::string& pattern, int index) {
  static const std::regex kOne(R"(^[^%]*%0?[0-9]*d[^%]*$)");
  if (!std::regex_match(pattern, kOne))
    throw render::RenderInputError("-o '" + pattern +
                                   "': expected a pattern with one frame number, e.g. "
                                   "frames/f%03d.png");
  char path[4096];
  std::snprintf(path, sizeof path, pattern.c_str(), index);
  return path;
}

/// Frames written while the next ones are drawn: each file is encoded and written on a thread of its own, at most
/// `inFlight` at once (the oldest waited for first), so that the renderer never waits for PNG or JPEG encoding unless
/// encoding falls that far behind. A write that fails is rethrown (naming its file) by the write after it or by
/// finish().
class PipelinedWriter {
 public:
  explicit PipelinedWriter(size_t inFlight) : mInFlight(std::max<size_t>(inFlight, 1)) {}
  ~PipelinedWriter() {
    for (auto& f : mPending)
      if (f.valid()) f.wait();
  }
  void write(std::string path, image::Image8 frame, image::ImageWriteOptions options) {
    if (mPending.size() >= mInFlight) waitOldest();
    mPending.push_back(std::async(std::launch::async, [path = std::move(path), frame = std::move(frame), options] {
      image::writeImage(path, frame, options);
    }));
  }
  void finish() {
    while (!mPending.empty()) waitOldest();
  }

 private:
  void waitOldest() {
    std::future<void> oldest = std::move(mPending.front());
    mPending.pop_front();
    oldest.get();
  }

  size_t mInFlight;
  std::deque<std::future<void>> mPending;
};

/// The turntable's scene: the scene options' orbit camera (default azimuth 30, elevation 20, distance 2.5), its
/// elevation replaced by --elevation when given; frame i turns the azimuth by 360·i/N degrees.
render::Scene orbitScene(const OrbitArgs& a, const CLI::App& cmd) {
  render::Scene scene = buildScene(a.scene, cmd);
  if (!scene.camera.orbit)
    throw render::RenderInputError("orbit turns an orbit camera (--orbit AZ,EL,DIST); an explicit --eye cannot turn");
  if (cmd.count("--elevation")) scene.camera.elevation = a.elevation;
  return scene;
}

/// One view drawn as an interactive frame (at the rate of the orbit's earlier frames, interactive and exact, as a
/// server session predicts from its own), then exactly: the interactive frame is returned and the line reports its
/// budget, predicted and actual ms, its choice and its PSNR against the exact frame.
struct InteractiveView {
  image::ImageF frame;
  double actualMs = 0, psnr = 0;
};

InteractiveView interactiveView(render::RenderEngine& engine, const std::shared_ptr<const render::Dataset>& dataset,
                                render::Scene scene, render::RateGauge& rate, int index) {
  InteractiveView out;
  render::FrameStats stats;
  render::FrameOptions options;
  options.rateSamplesPerMs = rate.rate();
  options.fixedMs = rate.fixedMs();
  scene.interactive = true;
  out.frame = engine.render(dataset, scene, &stats, options);
  const nlohmann::json& chosen = stats.interactive;
  out.actualMs = chosen.value("actual_ms", 0.0);
  rate.add(stats.samplesEstimated, out.actualMs);
  scene.interactive = false;
  render::FrameStats exactStats;
  const image::ImageF exact = engine.render(dataset, scene, &exactStats);
  rate.add(exactStats.samplesEstimated, exactStats.msTotal);  // as a server session's exact frames do
  out.psnr = image::compareImages(out.frame, exact).psnr;
  std::printf("view %d: azimuth %g, budget %.0f ms, predicted %.1f ms, actual %.1f ms, %dx%d step %g lod %g, %.1f dB\n",
              index, scene.camera.azimuth, scene.timeBudgetMs, chosen.value("predicted_ms", 0.0), out.actualMs,
              chosen.value("width", 0), chosen.value("height", 0), chosen.value("step", 0.0), chosen.value("lod", 0.0),
              out.psnr);
  return out;
}

void runOrbit(const OrbitArgs& a, const CLI::App& cmd) {
  render::Scene scene = orbitScene(a, cmd);
  if (a.interactiveMs > 0) scene.timeBudgetMs = a.interactiveMs;
  const std::string first = framePath(a.pattern, 0);
  image::imageFormatFor(first);  // refused before anything is drawn
  checkOutputFormat(scene, first);
  const std::filesystem::path dir = std::filesystem::path(first).parent_path();
  if (!dir.empty()) std::filesystem::create_directories(dir);
  const auto dataset = render::openDataset(a.store, a.store, size_t(a.hostBudgetMB) << 20,
                                           store::StoreOpenOptions{a.grid, a.brick, a.time, a.channel});
  render::RenderEngineOptions options;
  options.backend = render::parseBackend(a.backend);
  options.gpuBudgetBytes = size_t(a.gpuBudgetMB) << 20;
  render::RenderEngine engine(options);
  if (!a.quiet) std::fprintf(stderr, "orbit: %s\n", engine.describe().c_str());
  const double start = scene.camera.azimuth;
  double totalMs = 0;
  render::RateGauge rate;
  // Encoders beside the render thread: as many as the cores left to them.
  PipelinedWriter writer(std::max(1u, std::thread::hardware_concurrency()) - 1);
  // The wall time a frame is counted from the first frame's delivery: the first also makes the renderer (its atlas).
  std::chrono::steady_clock::time_point firstDone;
  int within = 0;
  double worstPsnr = std::numeric_limits<double>::infinity();
  auto written = [&](int i, image::Image8&& frame, double ms, double azimuth) {
    if (i == 0) firstDone = std::chrono::steady_clock::now();
    writer.write(framePath(a.pattern, i), std::move(frame), {a.jpegQuality});
    totalMs += ms;
    if (!a.quiet) std::fprintf(stderr, "orbit: frame %d/%d, azimuth %g, %.1f ms\n", i + 1, a.frames, azimuth, ms);
  };
  if (a.interactiveMs > 0) {
    for (int i = 0; i < a.frames; ++i) {
      scene.camera.azimuth = start + 360.0 * i / a.frames;
      InteractiveView view = interactiveView(engine, dataset, scene, rate, i);
      within += view.actualMs <= 1.5 * a.interactiveMs;
      worstPsnr = std::min(worstPsnr, view.psnr);
      written(i, image::toImage8(view.frame), view.actualMs, scene.camera.azimuth);
    }
  } else {
    // Finished on the GPU as the server's frames are, each next frame planned while the GPU draws the last.
    std::vector<render::Scene> turn(size_t(a.frames), scene);
    for (int i = 0; i < a.frames; ++i) turn[size_t(i)].camera.azimuth = start + 360.0 * i / a.frames;
    engine.renderSequence8(dataset, turn, {}, [&](size_t i, image::Image8&& frame, const render::FrameStats& stats) {
      written(int(i), std::move(frame), stats.msTotal, turn[i].camera.azimuth);
    });
  }
  writer.finish();
  const double wallMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - firstDone).count();
  std::printf("orbit: wrote %d frames (%dx%d) to %s, %.1f ms a frame drawn",
              a.frames, scene.width, scene.height, a.pattern.c_str(), totalMs / a.frames);
  if (a.frames > 1)
    std::printf(", %.1f ms a frame in all after the first (the next frame planned and the files encoded beside the "
                "drawing)",
                wallMs / (a.frames - 1));
  std::printf("\n");
  if (a.interactiveMs > 0)
    std::printf("orbit: %d of %d interactive frames within 1.5x their %g ms budget, the worst %.1f dB\n", within,
                a.frames, a.interactiveMs, worstPsnr);
}

}  // namespace

void addOrbitCommand(CLI::App& app) {
  auto a = std::make_shared<OrbitArgs>();
  CLI::App* cmd = app.add_subcommand("orbit", "Render a turntable: N frames about the volume, from one warm renderer");
  cmd->add_option("dataset", a->store, "store directory, or a .vdb file or OME-Zarr directory to read live")
      ->required();
  cmd->add_option("-o,--output", a->pattern, "frame files, a pattern with one frame number: frames/f%03d.png (or .jpg)")
      ->required();
  cmd->add_option("--frames", a->frames, "frames in the full turn")->capture_default_str()->check(between(1, 100000));
  cmd->add_option("--elevation", a->elevation, "degrees above the equator (default: the --orbit camera's, 20)")
      ->check(between(-90, 90, "degrees"));
  addZarrIndexOptions(cmd, a->time, a->channel);
  cmd->add_option("--grid", a->grid, ".vdb: the float grid to read (default: the first float grid)");
  cmd->add_option("--brick", a->brick, ".vdb: brick size B, a power of two in [8, 256]")
      ->capture_default_str()
      ->check(between(8, 256, "voxels"));
  cmd->add_option("--jpeg-quality", a->jpegQuality, "JPEG quality of .jpg/.jpeg frames")
      ->capture_default_str()
      ->check(between(1, 100));
  addSceneOptions(cmd, a->scene);
  cmd->add_option("--backend", a->backend, "auto, egl or osmesa")->capture_default_str();
  cmd->add_option("--gpu-budget", a->gpuBudgetMB, "MB of GPU memory for the brick atlas")
      ->capture_default_str()
      ->check(between(16, 1 << 22, "MB"));
  cmd->add_option("--host-cache", a->hostBudgetMB, "MB of host memory for decoded bricks (serve's --host-cache)")
      ->capture_default_str()
      ->check(between(0, 1 << 22, "MB"));
  cmd->add_option("--interactive", a->interactiveMs,
                  "draw each view as an interactive frame within this many ms (a coarser drawing scaled up), and "
                  "report its budget, predicted and actual ms and its PSNR against the exact frame of the view")
      ->check(between(render::Scene::kMinTimeBudgetMs, render::Scene::kMaxTimeBudgetMs, "ms"));
  cmd->add_flag("-q,--quiet", a->quiet, "no progress lines");
  cmd->callback([a, cmd] {
    keepFreedMemoryForFrames();
    runOrbit(*a, *cmd);
  });
}

}  // namespace voxbrick::cli
