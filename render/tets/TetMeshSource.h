// Where a tetrahedral mesh's frames get their tets: the whole mesh held in memory, or a mesh store paged by view (the
// points stay in memory and each frame reads only the chunks its view reaches and its transfer function does not make
// transparent; mesh/FORMAT.md: a chunk's bounds and value range). Shared read-only by every render thread. GL-free.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include "brickstore/read/BrickCache.h"
#include "mesh/MeshStore.h"
#include "render/core/FrameStats.h"
#include "render/core/PartialFrame.h"
#include "render/core/Scene.h"
#include "render/tets/MeshPartition.h"
#include "render/tets/TetMeshData.h"
#include "render/tets/TetView.h"

namespace voxbrick::render {

/// Where a mesh's frames get their tets. One per dataset, shared by every render thread (thread-safe).
class TetMeshSource {
 public:
  /// The whole mesh, held in memory; `chunks`: the index of the store it was read from, if any (what partitions
  /// weigh: partWeights).
  explicit TetMeshSource(std::shared_ptr<const TetMeshData> whole, std::vector<mesh::ChunkInfo> chunks = {});
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
  /// With `part` (sort-last rendering, FrameOptions::meshPart): of a whole mesh, the cells whose box meets the part's
  /// (cellsMeeting, made once per part and kept); of a paged one, only the chunks whose box meets it besides (a chunk
  /// is read whole: its cells outside the part are walked and add nothing).
  /// Throws RenderLimitError when the working set does not fit what the budget leaves (after dropping every kept
  /// set no frame is using), naming both sizes; store::CorruptStoreError when a chunk fails its checks.
  std::shared_ptr<const TetMeshData> frameData(const Scene& scene, const TetView& view, FrameStats* stats,
                                               const MeshPartBox* part = nullptr) const;

  /// What a partition of the mesh into sort-last parts balances (partitionMesh): its store's chunks by their stored
  /// bytes (the same whether the mesh is held whole or paged), or a mesh not read from a store its cells, one each.
  std::vector<WeightedBox> partWeights() const;

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
  /// A whole mesh's part (cellsMeeting), made once for its box; null when no cell meets it.
  std::shared_ptr<const TetMeshData> wholePart(const MeshPartBox& box) const;

  TetMeshConstants mConstants;
  std::shared_ptr<const TetMeshData> mWhole;
  std::vector<mesh::ChunkInfo> mChunks;  // a whole mesh's store index, if it was read from one
  std::unique_ptr<Paged> mPaged;
  mutable std::mutex mPartsMutex;  // mParts
  /// A whole mesh's parts drawn lately (a rank draws one), newest last.
  mutable std::vector<std::pair<MeshPartBox, std::shared_ptr<const TetMeshData>>> mParts;
};

}  // namespace voxbrick::render
