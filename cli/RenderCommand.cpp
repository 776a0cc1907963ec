// `voxbrick render STORE -o out.png`: one frame, headless, with its statistics.
#include <cstdio>

#include <nlohmann/json.hpp>

#include "brickstore/InputErrors.h"
#include "cli/Commands.h"
#include "cli/MpiOptions.h"
#include "cli/Progress.h"
#include "cli/SceneOptions.h"
#include "distributed/Cluster.h"
#include "distributed/RankRenderer.h"
#include "image/ImageFile.h"
#include "render/core/Dataset.h"
#include "render/core/RenderErrors.h"
#include "render/core/Scene.h"
#include "render/datasets/Datasets.h"
#include "render/engine/RenderEngine.h"
#include "render/reference/ReferenceRenderer.h"
#include "render/reference/TetReference.h"
#include "render/tets/TetMeshDataset.h"
#include "render/volume/BrickStoreDataset.h"

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
/// within --host-budget; an error names the input.
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
void writeFrame(const RenderArgs& a, const std::string& path, const image::ImageF& frame) {
  image::writeImage(path, image::toImage8(frame), {a.jpegQuality});
}

/// Runs `draw`, showing how long it has been drawing once that passes a second (Progress::elapsed) unless --quiet.
template <typename Draw>
image::ImageF withProgress(const RenderArgs& a, const render::Scene& scene, Draw&& draw) {
  Progress progress(a.quiet);
  image::ImageF image;
  {
    ElapsedTicker ticker(progress,
                         "render: drawing " + std::to_string(scene.width) + "x" + std::to_string(scene.height));
    image = draw();
  }
  progress.finish();
  return image;
}

/// The CPU reference: slow on purpose, double precision, the same store and scene.
/// The exact reference of a tetrahedral mesh (render/reference/TetReference.h): every ray's segments through the tets,
/// integrated in closed form.
void runTetReference(const RenderArgs& a, const render::Scene& scene, const render::TetMeshDataset& dataset) {
  if (!a.analytic.empty()) throw render::RenderInputError("--analytic samples a grid's field; a mesh has none");
  // A paged mesh gives the reference the chunks the frame needs (those in view that the transfer function does not
  // make transparent: the rest adds nothing to any ray), as it gives the GPU renderer.
  const render::TetMeshSource& source = *dataset.source();
  const std::shared_ptr<const render::TetMeshData> d =
      source.frameData(scene, render::TetView::of(scene, source.constants()), nullptr);
  const render::TetReference reference(d ? d->mesh : mesh::TetMesh{});
  render::TetReferenceStats stats;
  const image::ImageF image = withProgress(a, scene, [&] {
    return reference.render(render::TetReferenceParams::fromScene(scene, source.constants()), &stats);
  });
  writeFrame(a, a.output, image);
  if (!a.statsPath.empty())
    writeText(a.statsPath, nlohmann::json{{"rays", stats.rays},
                                          {"segments", stats.segments},
                                          {"tet_tests", stats.tetTests},
                                          {"ambiguous", stats.ambiguous},
                                          {"ms", stats.ms}}
                                   .dump(2) +
                               "\n");
  std::printf("render: wrote %s (%dx%d) with the exact tet reference: %lld rays, %lld segments, %.1f ms\n",
              a.output.c_str(), scene.width, scene.height, (long long)stats.rays, (long long)stats.segments, stats.ms);
}

void runReference(const RenderArgs& a, const render::Scene& scene, const render::Dataset& dataset) {
  if (const auto* tets = dynamic_cast<const render::TetMeshDataset*>(&dataset)) return runTetReference(a, scene, *tets);
  const auto* grid = dynamic_cast<const render::BrickStoreDataset*>(&dataset);
  if (!grid)
    throw render::RenderInputError("--backend reference renders brick stores; '" + a.store + "' is a " +
                                   render::datasetKindName(dataset.kind()));
  render::ReferenceOptions options;
  options.step = a.referenceStep;
  if (!a.analytic.empty()) options.analytic = render::analyticFieldFor(grid->store()->meta(), a.analytic);
  render::ReferenceRenderer renderer(grid->cache());
  render::ReferenceStats stats;
  const image::ImageF image = withProgress(a, scene, [&] { return renderer.render(scene, options, &stats); });
  writeFrame(a, a.output, image);
  if (!a.statsPath.empty())
    writeText(
        a.statsPath,
        nlohmann::json{
            {"rays", stats.rays}, {"samples", stats.samples}, {"bricks_skipped", stats.bricksSkipped}, {"ms", stats.ms}}
                .dump(2) +
            "\n");
  std::printf("render: wrote %s (%dx%d) with the reference (%s, step %g voxels): %lld rays, %lld samples, %.1f ms\n",
              a.output.c_str(), scene.width, scene.height, options.analytic ? "analytic field" : "trilinear grid",
              options.step, (long long)stats.rays, (long long)stats.samples, stats.ms);
}

/// A --sub-block typed on the command line must cut the dataset's bricks: a power of two below the brick size (the
/// renderer alone takes one equal to it as whole bricks, since the scene's default of 8 meets bricks of 8).
void checkSubBlock(const RenderArgs& a, const CLI::App& cmd, const render::Dataset& dataset) {
  const auto* grid = dynamic_cast<const render::BrickStoreDataset*>(&dataset);
  if (!grid || !cmd.count("--sub-block") || a.scene.subBlock == 0) return;
  const int B = grid->store()->brickSize();
  if (a.scene.subBlock >= B)
    throw render::RenderInputError("--sub-block " + std::to_string(a.scene.subBlock) +
                                   " must be 0 (whole bricks) or a power of two below the brick size " +
                                   std::to_string(B) + " of '" + a.store + "'");
}

/// Progressive: the frame that waits for no disk read (stand-ins for what is not resident), written beside the
/// output when there were any; its statistics.
nlohmann::json renderProvisional(const RenderArgs& a, render::RenderEngine& engine,
                                 const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene) {
  render::FrameStats first;
  const image::ImageF provisional = engine.render(dataset, scene, &first, {render::RenderMode::Normal, true});
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

/// The line (or lines) about the frame written: a paged mesh's paging, then the mesh's or the grid's counts and times.
void printFrameSummary(const RenderArgs& a, const render::Scene& scene, const render::Dataset& dataset,
                       const render::FrameStats& stats) {
  std::string levels;
  if (stats.bricksCoarse > 0) {
    levels = " (per level:";
    for (int64_t n : stats.bricksPerLevel) levels += " " + std::to_string(n);
    levels += ")";
  }
  if (const auto* tets = dynamic_cast<const render::TetMeshDataset*>(&dataset); tets && tets->source()->paged()) {
    const store::CacheStats c = tets->cacheStats();
    std::printf(
        "render: mesh paged within %.1f MiB: %lld of %zu chunks in view, %lld of those left out as "
        "transparent; %lld chunk reads in all, paging %.1f ms this frame; %.1f MiB held at most\n",
        double(c.budgetBytes) / 1048576.0, (long long)(int64_t(tets->source()->chunkCount()) - stats.tetChunksCulled),
        tets->source()->chunkCount(), (long long)stats.tetChunksSkippedEmpty, (long long)c.bricksDecoded,
        stats.msPaging, double(c.peakResidentBytes) / 1048576.0);
  }
  if (dataset.kind() == render::DatasetKind::TetMesh && stats.tetRayPasses > 0) {
    std::printf(
        "render: wrote %s (%dx%d): %lld tet segments ray cast (%lld rays, %lld terminated early, %lld "
        "pass%s), %.1f ms (pre-integration %.1f, drawing %.1f, readback %.1f)\n",
        a.output.c_str(), scene.width, scene.height, (long long)stats.samples, (long long)stats.fragments,
        (long long)stats.samplesTerminated, (long long)stats.tetRayPasses, stats.tetRayPasses == 1 ? "" : "es",
        stats.msTotal, stats.msPreIntegration, stats.msDrawing, stats.msReadback);
    return;
  }
  if (dataset.kind() == render::DatasetKind::TetMesh) {
    std::printf(
        "render: wrote %s (%dx%d): %lld tets drawn in %s order, %lld fragments, %.1f ms (sorting %.1f, "
        "pre-integration %.1f, drawing %.1f, readback %.1f)\n",
        a.output.c_str(), scene.width, scene.height, (long long)stats.tetsDrawn,
        render::tetSortName(scene.visibility == render::TetSort::Centroid ? render::TetSort::Centroid
                                                                          : render::TetSort::Mpvo),
        (long long)stats.fragments, stats.msTotal, stats.msSorting, stats.msPreIntegration, stats.msDrawing,
        stats.msReadback);
    return;
  }
  std::printf(
      "render: wrote %s (%dx%d): %lld bricks drawn%s, %lld skipped empty, %lld culled, %lld paged in, "
      "%lld evicted, %lld batches, %.1f ms (paging %.1f, slicing %.1f, drawing %.1f, readback %.1f)\n",
      a.output.c_str(), scene.width, scene.height, (long long)stats.bricksDrawn, levels.c_str(),
      (long long)stats.bricksSkippedEmpty, (long long)stats.bricksCulled, (long long)stats.bricksPagedIn,
      (long long)stats.bricksEvicted, (long long)stats.batches, stats.msTotal, stats.msPaging, stats.msSlicing,
      stats.msDrawing, stats.msReadback);
  if (stats.bricksFitCoarsened > 0)
    std::printf(
        "render: the frame was coarsened to fit: its levels wanted %.1f MiB of bricks, the atlas holds %.1f MiB; "
        "%lld bricks drawn as their parents, levels %d to %d\n",
        double(stats.bytesWanted) / 1048576.0, double(stats.bytesBudget) / 1048576.0,
        (long long)stats.bricksFitCoarsened, stats.levelFinest, stats.levelCoarsest);
}

/// The checks of the arguments against the scene and the opened dataset, the same with and without --mpi:
/// --sub-block against its bricks, the output's format against the scene, --analytic only with the reference.
void checkInput(const RenderArgs& a, const CLI::App& cmd, const render::Scene& scene, const render::Dataset& dataset) {
  checkSubBlock(a, cmd, dataset);
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
  const auto dataset = distributed::openOnEveryRank(
      MPI_COMM_WORLD, a.store, a.store, [&] { return openInput(a); }, a.mpi.timeout);
  checkInput(a, cmd, scene, *dataset);
  render::RenderEngine engine(engineOptions(a));
  distributed::RankRendererOptions options;
  options.composite = compositeOptions(a.mpi);
  distributed::RankRenderer renderer(MPI_COMM_WORLD, engine, options);
  // An interactive frame is chosen by rank 0's rate on every rank (the same reduced drawing everywhere).
  auto frameOptions = [&] {
    render::FrameOptions o;
    o.rateSamplesPerMs =
        distributed::agreedRate(MPI_COMM_WORLD, engine.recentRate(render::DatasetKind::BrickStore), a.mpi.timeout);
    return o;
  };
  for (int i = 0; i < a.warmUp; ++i) renderer.render(dataset, scene, nullptr, nullptr, frameOptions());
  render::FrameStats stats;
  nlohmann::json distributedJson;
  const image::ImageF image = renderer.render(dataset, scene, &stats, &distributedJson, frameOptions());
  if (mpi.rank() != 0) return;
  writeFrame(a, a.output, image);
  if (!a.statsPath.empty()) {
    nlohmann::json json = stats.toJson();
    json["distributed"] = distributedJson;
    writeText(a.statsPath, json.dump(2) + "\n");
  }
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
  for (int i = 0; i < a.warmUp; ++i) engine.render(dataset, scene, nullptr);
  // Progressive: first the frame that waits for no disk read, then the exact one.
  const nlohmann::json provisionalJson =
      scene.progressive ? renderProvisional(a, engine, dataset, scene) : nlohmann::json();
  render::FrameStats stats;
  const image::ImageF image = withProgress(a, scene, [&] { return engine.render(dataset, scene, &stats); });
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
  cmd->add_option("store", args->store, "store directory, or a .vdb file or OME-Zarr directory to read live (no prep)")
      ->required();
  cmd->add_option("--time", args->time, "OME-Zarr: the index along its 't' axis")->check(CLI::NonNegativeNumber);
  cmd->add_option("--channel", args->channel, "OME-Zarr: the index along its 'c' axis")->check(CLI::NonNegativeNumber);
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
  cmd->add_option("--host-budget", args->hostBudgetMB, "MB of host memory for decoded bricks")
      ->capture_default_str()
      ->check(between(0, 1 << 22, "MB"));
  cmd->add_option("--atlas-format", args->atlasFormat,
                  "float (default: full-precision filtering), native (the store's type: less memory) or half")
      ->check(CLI::IsMember({"float", "native", "half"}));
  cmd->add_option("--uploads", args->uploads,
                  "how bricks reach the atlas: staged (a fenced ring of pixel buffers, overlapping the GPU's work), "
                  "direct, or auto (staged on a GPU, direct on a software rasteriser)")
      ->check(CLI::IsMember({"auto", "direct", "staged"}));
  cmd->add_option("--bricking", args->bricking,
                  "how bricks lie in the atlas: single (the volume's axis order) or multi-oriented (axis order "
                  "rotated from brick to brick, for texture caches that favour one direction; the same image)")
      ->capture_default_str()
      ->check(CLI::IsMember({"single", "multi-oriented"}));
  addMpiOptions(cmd, args->mpi, "sort-last across the ranks of mpirun: each rank draws a part, rank 0 writes");
  cmd->add_flag("-q,--quiet", args->quiet, "do not print the renderer's name, nor progress of a frame past a second");
  cmd->callback([args, cmd] {
    keepFreedMemoryForFrames();
    runRender(*args, *cmd);
  });
}

}  // namespace voxbrick::cli
