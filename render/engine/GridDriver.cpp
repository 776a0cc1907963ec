// The driver of brick stores: a prepped store directory, a .vdb or an OME-Zarr directory read live.
#include <algorithm>
#include <cstdio>

#include "brickstore/read/OpenAnyStore.h"
#include "brickstore/zarr/ZarrMeta.h"
#include "render/core/RenderErrors.h"
#include "render/engine/BuiltInDrivers.h"
#include "render/gl/GlContext.h"
#include "render/gl/volume/BrickAtlas.h"
#include "render/gl/volume/Residency.h"
#include "render/gl/volume/VolumeRenderer.h"
#include "render/reference/ReferenceRenderer.h"
#include "render/volume/BrickStoreDataset.h"
#include "render/volume/FramePlan.h"
#include "render/volume/Partition.h"

namespace voxbrick::render {
namespace {

const BrickStoreDataset& grid(const Dataset& dataset) { return static_cast<const BrickStoreDataset&>(dataset); }

/// A k-d partition of the store's level-0 bricks, and the order of its parts for a camera.
class GridParts final : public SortLastParts {
 public:
  GridParts(std::shared_ptr<const store::BrickStore> store, int parts)
      : mStore(std::move(store)), mPartition(partitionBricks(*mStore, parts)) {}
  int count() const override { return int(mPartition.boxes.size()); }
  void select(int part, FrameOptions& options) const override { options.part = mPartition.boxes.at(size_t(part)); }
  std::vector<int> frontToBack(const Scene& scene) const override {
    return partsFrontToBack(mPartition, partView(mStore->meta(), scene));
  }
  PixelRect footprint(int part, const Scene& scene, int width, int height, const FrameStats* drawn) const override {
    return partFootprint(mStore->meta(), mPartition.boxes.at(size_t(part)), scene, width, height,
                         drawn ? drawn->drawnBox : std::nullopt);
  }

 private:
  std::shared_ptr<const store::BrickStore> mStore;
  Partition mPartition;
};

class GridDriver final : public DatasetDriver {
 public:
  std::string_view kind() const override { return BrickStoreDataset::kKind; }

  bool recognises(const std::filesystem::path& path) const override {
    std::error_code ec;
    return std::filesystem::is_regular_file(path / "store.json", ec) || store::isVdbFile(path) ||
           store::isZarrDirectory(path);
  }
  DatasetReport describe(const std::filesystem::path& path, const store::StoreOpenOptions& options) const override {
    return describeGrid(path, options);
  }
  std::vector<std::filesystem::path> files(const std::filesystem::path& path) const override {
    // An OME-Zarr's identity is its metadata (a rewrite of the chunks alone is not seen; reopen it by name).
    if (store::isZarrDirectory(path)) return {path / ".zattrs", path / ".zgroup"};
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) return {path / "store.json", path / "bricks.bin"};
    return {path};
  }
  std::shared_ptr<const Dataset> open(std::string name, const std::filesystem::path& path, size_t cacheBytes,
                                      const store::StoreOpenOptions& options) const override {
    return std::make_shared<BrickStoreDataset>(std::move(name), path, cacheBytes, 2, options);
  }

  size_t gpuBytesWanted(const Dataset& dataset, const RendererSetup& setup) const override {
    return Residency::atlasBytes(*grid(dataset).store(), setup.options.gpuBudgetBytes, setup.options.atlasFormat,
                                 BrickAtlas::resolveUploads(setup.context, setup.options.atlasUploads));
  }
  std::unique_ptr<FrameRenderer> makeRenderer(const Dataset& dataset, const RendererSetup& setup) const override {
    return std::make_unique<VolumeRenderer>(setup.context, grid(dataset).cache(), setup.gpuBytesLeft,
                                            setup.options.atlasFormat, setup.options.atlasUploads,
                                            setup.options.atlasBricking);
  }
  void prefetch(const Dataset& dataset, const Scene& scene, const FrameRenderer* renderer) const override {
    // The bricks the frame will draw, fitted to the budget it will be fitted to (the renderer's atlas slots and the
    // host cache's bricks), so that nothing is paged that the frame will not draw.
    const BrickStoreDataset& g = grid(dataset);
    const BrickBudget budget = renderer ? static_cast<const VolumeRenderer&>(*renderer).budget() : BrickBudget{};
    const FramePlan plan = planFrame(scene, *g.store(), kTransferTableTexels, budget);
    std::vector<store::BrickKey> keys;
    for (const BrickDraw& d : plan.visible.bricks) {
      if (keys.size() >= g.cache()->prefetchQueueLimit()) break;
      keys.push_back(d.key);
    }
    g.cache()->prefetch(keys);
  }

  ReferenceFrame reference(const Dataset& dataset, const Scene& scene,
                           const ReferenceSettings& settings) const override {
    const BrickStoreDataset& g = grid(dataset);
    ReferenceOptions options;
    options.step = settings.step;
    if (!settings.analytic.empty()) options.analytic = analyticFieldFor(g.store()->meta(), settings.analytic);
    ReferenceRenderer renderer(g.cache());
    ReferenceStats stats;
    ReferenceFrame out;
    out.image = renderer.render(scene, options, &stats);
    out.stats = {{"rays", stats.rays}, {"samples", stats.samples}, {"bricks_skipped", stats.bricksSkipped},
                 {"ms", stats.ms}};
    out.summary = printed("with the reference (%s, step %g voxels): %lld rays, %lld samples, %.1f ms",
                         options.analytic ? "analytic field" : "trilinear grid", options.step, (long long)stats.rays,
                         (long long)stats.samples, stats.ms);
    return out;
  }

  std::vector<std::string> summary(const Dataset&, const Scene&, const FrameStats& stats,
                                   const std::string& written) const override {
    std::string levels;
    if (stats.bricksCoarse > 0) {
      levels = " (per level:";
      for (int64_t n : stats.bricksPerLevel) levels += " " + std::to_string(n);
      levels += ")";
    }
    const std::string kernel = stats.raycaster.empty() ? "" : " (" + stats.raycaster + " ray caster)";
    std::vector<std::string> lines{printed(
        "%s: %lld bricks drawn%s, %lld skipped empty, %lld culled, %lld paged in, %lld evicted, %lld batches%s, %.1f "
        "ms (paging %.1f, slicing %.1f, drawing %.1f, readback %.1f)",
        written.c_str(), (long long)stats.bricksDrawn, levels.c_str(), (long long)stats.bricksSkippedEmpty,
        (long long)stats.bricksCulled, (long long)stats.bricksPagedIn, (long long)stats.bricksEvicted,
        (long long)stats.batches, kernel.c_str(), stats.msTotal, stats.msPaging, stats.msSlicing, stats.msDrawing,
        stats.msReadback)};
    if (!stats.fallback.empty()) lines.push_back(stats.fallback);
    if (stats.bricksFitCoarsened > 0)
      lines.push_back(printed(
          "the frame was coarsened to fit: its levels wanted %.1f MiB of bricks, the atlas holds %.1f MiB; %lld "
          "bricks drawn as their parents, levels %d to %d",
          double(stats.bytesWanted) / 1048576.0, double(stats.bytesBudget) / 1048576.0,
          (long long)stats.bricksFitCoarsened, stats.levelFinest, stats.levelCoarsest));
    return lines;
  }

  void checkSubBlock(const Dataset& dataset, int subBlock) const override {
    // The renderer alone takes a sub-block equal to the brick size as whole bricks (the scene's default of 8 meets
    // bricks of 8); one asked for must cut them.
    const int B = grid(dataset).store()->brickSize();
    if (subBlock != 0 && subBlock >= B)
      throw RenderInputError("--sub-block " + std::to_string(subBlock) +
                             " must be 0 (whole bricks) or a power of two below the brick size " + std::to_string(B) +
                             " of '" + dataset.name() + "'");
  }

  bool sortsLast() const override { return true; }
  std::shared_ptr<const SortLastParts> partition(const Dataset& dataset, int parts) const override {
    return std::make_shared<const GridParts>(grid(dataset).store(), parts);
  }
};

}  // namespace

std::shared_ptr<const DatasetDriver> gridDriver() { return std::make_shared<const GridDriver>(); }

}  // namespace voxbrick::render
