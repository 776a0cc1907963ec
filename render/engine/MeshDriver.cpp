// The driver of tetrahedral mesh stores: held whole, or paged by view beyond the host budget.
#include <algorithm>
#include <cstdio>

#include "mesh/MeshStore.h"
#include "render/core/RenderErrors.h"
#include "render/engine/BuiltInDrivers.h"
#include "render/gl/GlContext.h"
#include "render/gl/tets/TetRenderer.h"
#include "render/reference/TetReference.h"
#include "render/tets/MeshPartition.h"
#include "render/tets/TetMeshDataset.h"

namespace voxbrick::render {
namespace {

const TetMeshDataset& meshOf(const Dataset& dataset) { return static_cast<const TetMeshDataset&>(dataset); }

/// A k-d partition of the mesh's box balanced by its store's chunks' stored bytes, and the order of its parts for a
/// camera.
class MeshParts final : public SortLastParts {
 public:
  MeshParts(std::shared_ptr<const TetMeshSource> source, int parts)
      : mSource(std::move(source)),
        mPartition(partitionMesh(mSource->partWeights(), mSource->constants().bounds, parts)) {}
  int count() const override { return int(mPartition.boxes.size()); }
  void select(int part, FrameOptions& options) const override {
    options.meshPart = mPartition.boxes.at(size_t(part));
  }
  std::vector<int> frontToBack(const Scene& scene) const override {
    return partsFrontToBack(mPartition, meshPartView(scene, mSource->constants()));
  }
  PixelRect footprint(int part, const Scene& scene, int width, int height, const FrameStats*) const override {
    return meshPartFootprint(mPartition.boxes.at(size_t(part)), mSource->constants(), scene, width, height);
  }

 private:
  std::shared_ptr<const TetMeshSource> mSource;
  MeshPartition mPartition;
};

class MeshDriver final : public DatasetDriver {
 public:
  std::string_view kind() const override { return TetMeshDataset::kKind; }

  bool recognises(const std::filesystem::path& path) const override { return mesh::looksLikeMeshStore(path); }
  std::vector<std::filesystem::path> files(const std::filesystem::path& path) const override {
    return {path / mesh::kMeshMetaFile, path / mesh::kMeshIndexFile, path / mesh::kMeshDataFile};
  }
  DatasetReport describe(const std::filesystem::path& path, const store::StoreOpenOptions&) const override {
    const mesh::MeshStore s = mesh::MeshStore::open(path);
    const mesh::MeshStoreInfo& i = s.info();
    return {mesh::describeMeshStore(s),
            {{"source", i.source},
             {"field", i.field},
             {"points", i.vertexCount},
             {"tets", i.tetCount},
             {"boundary_faces", i.boundaryFaceCount},
             {"chunks", i.chunkCount},
             {"tets_per_chunk", i.tetsPerChunk},
             {"bounds",
              {{i.boundsMin.x, i.boundsMin.y, i.boundsMin.z}, {i.boundsMax.x, i.boundsMax.y, i.boundsMax.z}}},
             {"value_range", {i.scalarMin, i.scalarMax}},
             {"bytes_raw", i.bytesRaw},
             {"bytes_stored", i.bytesStored}}};
  }
  std::shared_ptr<const Dataset> open(std::string name, const std::filesystem::path& path, size_t cacheBytes,
                                      const store::StoreOpenOptions&) const override {
    // A mesh that fits the host budget whole is read and checked once, here; a larger one is paged by view: its
    // points stay in memory, and each frame reads the chunks it needs (TetMeshSource).
    auto meshStore = std::make_shared<const mesh::MeshStore>(mesh::MeshStore::open(path));
    const mesh::MeshStoreInfo& info = meshStore->info();
    std::shared_ptr<const TetMeshSource> source;
    // The chunks' index is kept either way: sort-last parts are balanced by it, the same on every rank however
    // each holds the mesh.
    if (TetMeshData::hostBytes(info.tetCount, info.vertexCount, info.boundaryFaceCount) <= cacheBytes) {
      std::vector<mesh::ChunkInfo> chunks;
      for (size_t c = 0; c < meshStore->chunkCount(); ++c) chunks.push_back(meshStore->chunk(c));
      source = std::make_shared<const TetMeshSource>(
          std::make_shared<const TetMeshData>(meshStore->readAll(), meshStore->readTopology()), std::move(chunks));
    } else {
      source = std::make_shared<const TetMeshSource>(std::move(meshStore), cacheBytes);
    }
    return std::make_shared<TetMeshDataset>(std::move(name), path, std::move(source));
  }

  size_t gpuBytesWanted(const Dataset& dataset, const RendererSetup& setup) const override {
    // Its resident size, at most the whole budget (a larger mesh is streamed).
    return std::min(setup.options.gpuBudgetBytes,
                    TetRenderer::bytesFor(meshOf(dataset).source()->constants().tetCount));
  }
  std::unique_ptr<FrameRenderer> makeRenderer(const Dataset& dataset, const RendererSetup& setup) const override {
    return std::make_unique<TetRenderer>(setup.context, meshOf(dataset).source(), setup.gpuBytesLeft);
  }

  ReferenceFrame reference(const Dataset& dataset, const Scene& scene,
                           const ReferenceSettings& settings) const override {
    if (!settings.analytic.empty()) throw RenderInputError("--analytic samples a grid's field; a mesh has none");
    // A paged mesh gives the reference the chunks the frame needs (those in view that the transfer function does not
    // make transparent: the rest adds nothing to any ray), as it gives the GPU renderer.
    const TetMeshSource& source = *meshOf(dataset).source();
    const std::shared_ptr<const TetMeshData> d =
        source.frameData(scene, TetView::of(scene, source.constants()), nullptr);
    const TetReference reference(d ? d->mesh : mesh::TetMesh{});
    TetReferenceStats stats;
    ReferenceFrame out;
    out.image = reference.render(TetReferenceParams::fromScene(scene, source.constants()), &stats);
    out.stats = {{"rays", stats.rays},
                 {"segments", stats.segments},
                 {"tet_tests", stats.tetTests},
                 {"ambiguous", stats.ambiguous},
                 {"ms", stats.ms}};
    out.summary = printed("with the exact tet reference: %lld rays, %lld segments, %.1f ms", (long long)stats.rays,
                         (long long)stats.segments, stats.ms);
    return out;
  }

  bool sortsLast() const override { return true; }
  std::shared_ptr<const SortLastParts> partition(const Dataset& dataset, int parts) const override {
    return std::make_shared<const MeshParts>(meshOf(dataset).source(), parts);
  }

  std::vector<std::string> summary(const Dataset& dataset, const Scene& scene, const FrameStats& stats,
                                   const std::string& written) const override {
    std::vector<std::string> lines;
    const TetMeshDataset& m = meshOf(dataset);
    const std::string part = stats.tetPart.empty() ? "" : " (a part: " + stats.tetPart + ", clipped to its box)";
    if (m.source()->paged()) {
      const store::CacheStats c = m.cacheStats();
      lines.push_back(printed(
          "mesh paged within %.1f MiB: %lld of %zu chunks in view, %lld of those left out as transparent; %lld chunk "
          "reads in all, paging %.1f ms this frame; %.1f MiB held at most",
          double(c.budgetBytes) / 1048576.0, (long long)(int64_t(m.source()->chunkCount()) - stats.tetChunksCulled),
          m.source()->chunkCount(), (long long)stats.tetChunksSkippedEmpty, (long long)c.bricksDecoded,
          stats.msPaging, double(c.peakResidentBytes) / 1048576.0));
    }
    if (stats.tetRayPasses > 0) {
      lines.push_back(printed(
          "%s: %lld tet segments ray cast%s (%lld rays, %lld terminated early, %lld pass%s), %.1f ms "
          "(pre-integration %.1f, drawing %.1f, readback %.1f)",
          written.c_str(), (long long)stats.samples, part.c_str(), (long long)stats.fragments, (long long)stats.samplesTerminated,
          (long long)stats.tetRayPasses, stats.tetRayPasses == 1 ? "" : "es", stats.msTotal, stats.msPreIntegration,
          stats.msDrawing, stats.msReadback));
      return lines;
    }
    lines.push_back(printed(
        "%s: %lld tets drawn in %s order%s, %lld fragments, %.1f ms (sorting %.1f, pre-integration %.1f, drawing "
        "%.1f, readback %.1f)",
        written.c_str(), (long long)stats.tetsDrawn,
        tetSortName(scene.visibility == TetSort::Centroid ? TetSort::Centroid : TetSort::Mpvo), part.c_str(),
        (long long)stats.fragments, stats.msTotal, stats.msSorting, stats.msPreIntegration, stats.msDrawing,
        stats.msReadback));
    return lines;
  }
};

}  // namespace

std::shared_ptr<const DatasetDriver> meshDriver() { return std::make_shared<const MeshDriver>(); }

}  // namespace voxbrick::render
