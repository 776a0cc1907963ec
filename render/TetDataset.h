// A tetrahedral mesh as a dataset (seed 002): where a frame's tets come from, and what every frame of it needs (its
// world box, the default reference length). Either the whole mesh held in memory, or a mesh store paged by view: the
// points stay in memory and each frame reads only the chunks its view reaches and its transfer function does not
// make transparent (mesh/FORMAT.md: a chunk's bounds and value range). Shared read-only by every render thread.
// GL-free.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "brickstore/BrickCache.h"
#include "mesh/MeshStore.h"
#include "mesh/TetMesh.h"
#include "mesh/Topology.h"
#include "render/Camera.h"
#include "render/Dataset.h"
#include "render/FrameStats.h"
#include "render/Scene.h"

namespace voxbrick::render {

/// What every frame of a mesh uses, whatever part of it is drawn: all of the whole mesh, so that a frame drawn from
/// part of the tets equals one drawn from all of them.
struct TetMeshConstants {
  Box bounds;                  ///< the points' box, world units (the camera orbits its centre; vertices are centred on it)
  double meanEdgeLength = 1;   ///< over every tet's six edges: the default reference length (a "cell")
  double longestEdge = 1;      ///< the longest segment a ray can have in one tet
  float scalarMin = 0, scalarMax = 0;
  uint64_t tetCount = 0, pointCount = 0;
  std::string field;
};

/// Tets ready to draw: the whole mesh, or the part of it a frame needs (a paged mesh's working set), with the whole
/// mesh's constants. Built once, shared read-only.
struct TetMeshData : TetMeshConstants {
  mesh::TetMesh mesh;
  mesh::Topology topology;
  /// Per tet, the smallest and largest of its four scalars: the values inside it (linear) lie between, so a tet the
  /// transfer function makes transparent over that range adds nothing and is not drawn.
  std::vector<std::pair<float, float>> tetRanges;
  /// Different for every TetMeshData made in this process: a renderer that uploaded one knows it again by this.
  uint64_t id = 0;

  /// The whole of `mesh` (which must hold at least one tet with valid indices): the constants derived from it.
  TetMeshData(mesh::TetMesh mesh, mesh::Topology topology);
  /// Part of a larger mesh, `whole` its constants. The topology's boundary faces are the part's own: faces of the
  /// whole's boundary, and faces whose neighbour is not in the part.
  TetMeshData(mesh::TetMesh mesh, mesh::Topology topology, const TetMeshConstants& whole);

  /// The host bytes a mesh of these counts takes held whole: points and scalars (16 a point), tets, neighbours and
  /// value ranges (40 a tet), boundary faces (8 each).
  static size_t hostBytes(uint64_t tets, uint64_t points, uint64_t boundaryFaces);
};

/// How a frame sees a mesh: its camera about the whole mesh's box and the value window (GL-free; TetRenderer and
/// the exact reference both start from it).
struct TetView {
  Camera camera;
  double nearPlane = 0, farPlane = 0;
  glm::dmat4 clipFromWorld{1.0};  ///< projection times view, world coordinates (not centred on the box)
  double windowLo = 0, windowHi = 1;

  /// The view of a frame of `scene` on a mesh of `constants`; the window is the scene's, or the scalar range (made
  /// one wide when the range is a single value).
  static TetView of(const Scene& scene, const TetMeshConstants& constants);
};

/// Where a mesh's frames get their tets. One per dataset, shared by every render thread (thread-safe).
class TetMeshSource {
 public:
  /// The whole mesh, held in memory.
  explicit TetMeshSource(std::shared_ptr<const TetMeshData> whole);
  /// `store` paged by view within `hostBudget` bytes: its points and scalars (residentBytes) stay in memory, and
  /// each frame's working set (the chunks it needs, as a TetMeshData) takes what the budget leaves. Recent working
  /// sets are kept, least recently used dropped first. Throws RenderLimitError when the points alone exceed the
  /// budget, mesh::MeshError when the store's edge lengths cannot be read.
  TetMeshSource(std::shared_ptr<const mesh::MeshStore> store, size_t hostBudget);
  ~TetMeshSource();
  TetMeshSource(const TetMeshSource&) = delete;
  TetMeshSource& operator=(const TetMeshSource&) = delete;

  const TetMeshConstants& constants() const { return mConstants; }
  bool paged() const { return mPaged != nullptr; }
  /// The whole mesh; null when paged.
  const std::shared_ptr<const TetMeshData>& whole() const { return mWhole; }
  /// Chunks in the store (1 for a whole mesh).
  size_t chunkCount() const;

  /// The tets a frame of `scene` seen as `view` needs. A whole mesh: all of them. A paged one: the chunks whose box
  /// the view frustum reaches and, when scene.skipEmpty, whose value range the transfer function does not make
  /// transparent (their counts into stats: tetChunksCulled, tetChunksSkippedEmpty, and tetChunksRead when the
  /// working set was not kept from an earlier frame; msPaging). Nothing (a null pointer) when no chunk is needed.
  /// Throws RenderLimitError when the working set does not fit what the budget leaves (after dropping every kept
  /// set no frame is using), naming both sizes; store::CorruptStoreError when a chunk fails its checks.
  std::shared_ptr<const TetMeshData> frameData(const Scene& scene, const TetView& view, FrameStats* stats) const;

  /// A paged mesh's working sets as a cache: hits (frames given a kept set), misses (sets built), bricksDecoded
  /// and bytesDecoded (chunks read, 32 bytes a tet), evictions, residentBytes (points and the sets alive), budget.
  /// Zero for a whole mesh.
  store::CacheStats cacheStats() const;
  /// A paged mesh's new host budget (a server's share changes as datasets open); kept sets beyond it are dropped as
  /// soon as no frame uses them. Nothing for a whole mesh.
  void setBudget(size_t bytes) const;

  /// The host bytes a paged store keeps resident: its points and scalars (16 a point) and its chunks' records.
  static size_t residentBytes(const mesh::MeshStoreInfo& info);

 private:
  struct Paged;
  TetMeshConstants mConstants;
  std::shared_ptr<const TetMeshData> mWhole;
  std::unique_ptr<Paged> mPaged;
};

/// A mesh dataset: what the server and `render` open; RenderEngine draws it with a TetRenderer.
class TetMeshDataset final : public Dataset {
 public:
  /// A dataset of `source` under `name`, read from `path`.
  TetMeshDataset(std::string name, const std::filesystem::path& path, std::shared_ptr<const TetMeshSource> source);

  DatasetKind kind() const override { return DatasetKind::TetMesh; }
  /// {"kind": "tet-mesh", "tets", "points", "field", "bounds", "value_range", "reference_length", "paged",
  /// "chunks"}.
  std::string infoJson() const override;
  /// A paged mesh's working sets (TetMeshSource::cacheStats); zero for a mesh held whole.
  store::CacheStats cacheStats() const override { return mSource->cacheStats(); }
  void setCacheBudget(size_t bytes) const override { mSource->setBudget(bytes); }

  const std::shared_ptr<const TetMeshSource>& source() const { return mSource; }

 private:
  std::shared_ptr<const TetMeshSource> mSource;
};

}  // namespace voxbrick::render
