// `voxbrick render STORE -o out.png`: one frame, headless, with its statistics.
#include <cstdio>

#include <nlohmann/json.hpp>

#include "brickstore/format/InputErrors.h"
#include "cli/Commands.h"
#include "cli/MpiOptions.h"
#include "cli/Progress.h"
#include "cli/SceneOptions.h"
#include "common/EnumNames.h"
#include "distributed/Cluster.h"
#include "distributed/RankRenderer.h"
#include "image/ImageFile.h"
#include "render/core/Dataset.h"
#include "render/core/RenderErrors.h"
#include "render/core/Scene.h"
#include "render/engine/DatasetDriver.h"
#include "render/engine/Datasets.h"
#include "render/engine/RenderEngine.h"
#include "render/volume/AtlasFormat.h"

namespace voxbrick::cli {
namespace {

struct RenderArgs {
  SceneArgs scene;
  std::string store, output, statsPath, grid;
  int brick = 32;
  int64_t time = 0, channel = 0;
  std::string backend = "auto", atlasFormat = "float", uploads = "auto", bricking = "single", analytic;
  double referenceStep = 0.125;
  bool quiet = false;
  int warmUp = 0;
  int jpegQuality = 90;
  int64_t gpuBudgetMB = 1024, hostBudgetMB = 1024;
  MpiArgs mpi;  ///< --mpi: sort-last across the ranks of mpirun (distributed/)
};

/// The dataset the arguments name: a store, a .vdb (--grid, --brick) or an OME-Zarr (--time, --channel), read
/// within --host-cache; an error names the input.
std::shared_ptr<const render::Dataset> openInput(const RenderArgs& a) {
  return store::namingInput({a.store}, [&] {
    return render::openDataset(a.store, a.store, size_t(a.hostBudgetMB) << 20,
                               store::StoreOpenOptions{a.grid, a.brick, a.time, a.channel});
  });
}

/// The GPU engine the arguments ask for (backend, atlas budget, format, uploads and bricking).
render::RenderEngineOptions engineOptions(const RenderArgs& a) {
  return {render::parseBackend(a.backend), size_t(a.gpuBudgetMB) << 20, render::parseAtlasFormat(a.atlasFormat),
          render::parseAtlasUploads(a.uploads), render::parseAtlasBricking(a.bricking)};
}

/// Writes a frame in the format the path's extension names (PNG or JPEG), atomically.
void writeFrame(const RenderArgs& a, const std::string& path, const image::Image8& frame) {
  image::writeImage(path, frame, {a.jpegQuality});
}
void writeFrame(const RenderArgs& a, const std::string& path, const image::ImageF& frame) {
  writeFrame(a, path, image::toImage8(frame));
}

/// Runs `draw`, showing how long it has been drawing once that passes a second (Progress::elapsed) unless --quiet.
template <typename Draw>
auto withProgress(const RenderArgs& a, const render::Scene& scene, Draw&& draw) {
  Progress progress(a.quiet);
  decltype(draw()) result;
  {
    ElapsedTicker ticker(progress,
                         "render: drawing " + std::to_string(scene.width) + "x" + std::to_string(scene.height));
    result = draw();
  }
  progress.finish();
  return result;
}

/// The CPU reference of the dataset's kind (a grid's: double precision, trilinear or an analytic field; a mesh's:
/// every ray's segments integrated in closed form): slow on purpose, the same dataset and scene.
void runReference(const RenderArgs& a, const render::Scene& scene, const render::Dataset& dataset) {
  const render::DatasetDriver& driver = render::driverFor(dataset);
  const render::ReferenceFrame frame = withProgress(a, scene, [&] {
    return driver.reference(dataset, scene, {a.referenceStep, a.analytic});
  });
  writeFrame(a, a.output, frame.image);
  if (!a.statsPath.empty()) writeText(a.statsPath, frame.stats.dump(2) + "\n");
  std::printf("render: wrote %s (%dx%d) %s\n", a.output.c_str(), scene.width, scene.height, frame.summary.c_str());
}

/// A --sub-block typed on the command line must suit the dataset (a grid's must cut its bricks; the renderer alone
/// takes one equal to the brick size as whole bricks, since the scene's default of 8 meets bricks of 8).
void checkSubBlock(const CLI::App& cmd, const render::GridTechnique& technique, const render::Dataset& dataset) {
  if (!cmd.count("--sub-block")) return;
  render::driverFor(dataset).checkSubBlock(dataset, technique.subBlock);
}

/// Progressive: the frame that waits for no disk read (stand-ins for what is not resident), written beside the
/// output when there were any; its statistics.
nlohmann::json renderProvisional(const RenderArgs& a, render::RenderEngine& engine,
                                 const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene) {
  render::FrameStats first;
  const image::Image8 provisional = engine.render8(dataset, scene, &first, {render::RenderMode::Normal, true});
  if (first.bricksStandIn > 0) {
    const std::string path = provisionalPath(a.output);
    writeFrame(a, path, provisional);
    std::printf("render: wrote %s, the provisional frame: %lld of %lld bricks stood in, %.1f ms\n", path.c_str(),
                (long long)first.bricksStandIn, (long long)first.bricksDrawn, first.msTotal);
  }
  return first.toJson();
}

/// What quality by target chose, if the scene asked for it.
void printQualityChoice(const render::FrameStats& stats) {
  if (stats.quality.is_null()) return;
  const auto& q = stats.quality;
  std::printf("render: quality %s chose %s (%s; measured worst view %.1f dB, %.0f ms expected at this size)%s\n",
              q["target"].get<std::string>().c_str(), q["setting"].get<std::string>().c_str(),
              q["basis"].get<std::string>().c_str(), q["expected_psnr"].get<double>(), q["expected_ms"].get<double>(),
              q["met"].get<bool>() ? "" : "; NO setting meets the target: the closest");
}

/// The lines about the frame written, as the dataset's kind tells them.
void printFrameSummary(const RenderArgs& a, const render::Scene& scene, const render::Dataset& dataset,
                       const render::FrameStats& stats) {
  const std::string written =
      "wrote " + a.output + " (" + std::to_string(scene.width) + "x" + std::to_string(scene.height) + ")";
  for (const std::string& line : render::driverFor(dataset).summary(dataset, scene, stats, written))
    std::printf("render: %s\n", line.c_str());
}

/// The checks of the arguments against the scene and the opened dataset, the same with and without --mpi:
/// --sub-block against its bricks, the output's format against the scene, --analytic only with the reference.
void checkInput(const RenderArgs& a, const CLI::App& cmd, const render::Scene& scene, const render::Dataset& dataset) {
  checkSubBlock(cmd, scene, dataset);
  checkOutputFormat(scene, a.output);
  if (a.mpi.mpi && a.backend == "reference")
    throw render::RenderInputError("--backend reference does not run with --mpi");
  if (a.backend != "reference" && !a.analytic.empty())
    throw render::RenderInputError(a.mpi.mpi ? "--analytic needs --backend reference, which does not run with --mpi"
                                             : "--analytic needs --backend reference");
}

/// `render --mpi` under mpirun: every rank opens the dataset (the same on every rank, or refused naming the rank),
/// draws its part with its own engine and budgets, the parts are composited, and rank 0 writes the frame and stats.
void runRenderMpi(const RenderArgs& a, const CLI::App& cmd) {
  distributed::MpiSession mpi;
  const render::Scene scene = buildScene(a.scene, cmd);
  const distributed::RankGroup everyRank = distributed::RankGroup::all(MPI_COMM_WORLD);
  const auto dataset = distributed::openOnEveryRank(
      everyRank, a.store, a.store, [&] { return openInput(a); }, a.mpi.timeout);
  checkInput(a, cmd, scene, *dataset);
  render::RenderEngine engine(engineOptions(a));
  distributed::RankRendererOptions options;
  options.composite = compositeOptions(a.mpi);
  distributed::RankRenderer renderer(MPI_COMM_WORLD, engine, options);
  // An interactive frame is chosen by rank 0's rate on every rank (the same reduced drawing everywhere).
  auto frameOptions = [&] {
    render::FrameOptions o;
    o.rateSamplesPerMs = distributed::agreedRate(everyRank, engine.recentRate(*dataset), a.mpi.timeout);
    return o;
  };
  for (int i = 0; i < a.warmUp; ++i) renderer.render(everyRank, dataset, scene, nullptr, frameOptions());
  render::FrameStats stats;
  const image::ImageF image = renderer.render(everyRank, dataset, scene, &stats, frameOptions());
  if (mpi.rank() != 0) return;
  writeFrame(a, a.output, image);
  if (!a.statsPath.empty()) writeText(a.statsPath, stats.toJson().dump(2) + "\n");
  const nlohmann::json& distributedJson = stats.distributed;
  std::printf("render: wrote %s (%dx%d) on %d ranks: compositing %.1f ms, %llu bytes exchanged\n", a.output.c_str(),
              scene.width, scene.height, mpi.size(), distributedJson["compositing_ms"].get<double>(),
              (unsigned long long)distributedJson["bytes_exchanged"].get<uint64_t>());
}

/// A GPU frame through the same seam the server's render threads use: a dataset and a RenderEngine.
void runRender(const RenderArgs& a, const CLI::App& cmd) {
  image::imageFormatFor(a.output);  // an output we cannot write is refused before the frame is drawn
  if (a.mpi.mpi) return runRenderMpi(a, cmd);
  const render::Scene scene = buildScene(a.scene, cmd);
  const auto dataset = openInput(a);
  checkInput(a, cmd, scene, *dataset);
  if (a.backend == "reference") return runReference(a, scene, *dataset);
  render::RenderEngine engine(engineOptions(a));
  if (!a.quiet) std::fprintf(stderr, "render: %s\n", engine.describe().c_str());
  // Warm-up frames page the bricks in and build the programs, so that the frame reported is a warm one, as a
  // server's next frame of the same dataset would be.
  // Frames are drawn as the server draws them, finished on the GPU as 8 bits (RenderEngine::render8).
  for (int i = 0; i < a.warmUp; ++i) engine.render8(dataset, scene, nullptr);
  // Progressive: first the frame that waits for no disk read, then the exact one.
  const nlohmann::json provisionalJson =
      scene.progressive ? renderProvisional(a, engine, dataset, scene) : nlohmann::json();
  render::FrameStats stats;
  const image::Image8 image = withProgress(a, scene, [&] { return engine.render8(dataset, scene, &stats); });
  writeFrame(a, a.output, image);
  if (!a.statsPath.empty()) {
    nlohmann::json json = stats.toJson();
    if (!provisionalJson.is_null()) json["provisional_frame"] = provisionalJson;
    writeText(a.statsPath, json.dump(2) + "\n");
  }
  printQualityChoice(stats);
  printFrameSummary(a, scene, *dataset, stats);
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand("render", "Render one frame of a store (or a .vdb, read live) to a PNG, headless");
  cmd->add_option("dataset", args->store,
                  "store directory, or a .vdb file or OME-Zarr directory to read live (no prep)")
      ->required();
  addZarrIndexOptions(cmd, args->time, args->channel);
  cmd->add_option("--grid", args->grid, ".vdb: the float grid to read (default: the first float grid)");
  cmd->add_option("--brick", args->brick, ".vdb: brick size B, a power of two in [8, 256]")
      ->capture_default_str()
      ->check(between(8, 256, "voxels"));
  cmd->add_option("-o,--output", args->output, "image to write: .png, or .jpg/.jpeg (JPEG)")->required();
  cmd->add_option("--jpeg-quality", args->jpegQuality, "JPEG quality of a .jpg/.jpeg output")
      ->capture_default_str()
      ->check(between(1, 100));
  cmd->add_option("--stats", args->statsPath, "write the frame statistics as JSON");
  cmd->add_option("--warm-up", args->warmUp, "render the frame this many times before the one written and timed")
      ->capture_default_str()
      ->check(between(0, 100));
  addSceneOptions(cmd, args->scene);
  cmd->add_option("--backend", args->backend,
                  "auto, egl or osmesa (a GL context), or reference (the CPU reference renderer)")
      ->capture_default_str();
  cmd->add_option("--reference-step", args->referenceStep, "reference: integration step in voxels")
      ->capture_default_str()
      ->check(between(0.001, 64, "voxels"));
  cmd->add_option("--analytic", args->analytic,
                  "reference: sample this synthetic field (NAME[,k=v...] as after synthetic:) instead of the grid");
  cmd->add_option("--gpu-budget", args->gpuBudgetMB, "MB of GPU memory for the brick atlas")
      ->capture_default_str()
      ->check(between(16, 1 << 22, "MB"));
  cmd->add_option("--host-cache", args->hostBudgetMB, "MB of host memory for decoded bricks (serve's --host-cache)")
      ->capture_default_str()
      ->check(between(0, 1 << 22, "MB"));
  cmd->add_option("--atlas-format", args->atlasFormat,
                  "float (default: full-precision filtering), native (the store's type: less memory) or half")
      ->check(CLI::IsMember(common::enumNameList<render::AtlasFormat>()));
  cmd->add_option("--uploads", args->uploads,
                  "how bricks reach the atlas: staged (a fenced ring of pixel buffers, overlapping the GPU's work), "
                  "direct, or auto (staged on a GPU, direct on a software rasteriser)")
      ->capture_default_str()
      ->check(CLI::IsMember(common::enumNameList<render::AtlasUploads>()));
  cmd->add_option("--bricking", args->bricking,
                  "how bricks lie in the atlas: single (the volume's axis order) or multi-oriented (axis order "
                  "rotated from brick to brick, for texture caches that favour one direction; the same image)")
      ->capture_default_str()
      ->check(CLI::IsMember(common::enumNameList<render::AtlasBricking>()));
  addMpiOptions(cmd, args->mpi, "sort-last across the ranks of mpirun: each rank draws a part, rank 0 writes");
  cmd->add_flag("-q,--quiet", args->quiet, "do not print the renderer's name, nor progress of a frame past a second");
  cmd->callback([args, cmd] {
    keepFreedMemoryForFrames();
    runRender(*args, *cmd);
  });
}

}  // namespace voxbrick::cli
