// Which of a mesh's tets a frame draws and how the GPU holds them: the frame's working set from its TetMeshSource
// (the whole mesh, or a paged mesh's chunks the view needs, held only while the frame draws them), whether the
// projected tets fit the GPU budget resident or are streamed in batches, and the ray caster's copy of the tets,
// made on first use where it fits beside them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "render/core/FrameStats.h"
#include "render/core/Scene.h"
#include "render/gl/GlFunctions.h"
#include "render/gl/tets/TetRayCaster.h"
#include "render/tets/TetMeshSource.h"
#include "render/tets/TetView.h"

namespace voxbrick::render {

/// One per renderer: the tets on the GPU and their share of its budget.
class TetResidency {
 public:
  static constexpr size_t kBytesPerTet = 64;     // four vec4: position and scalar
  static constexpr size_t kMinBatchTets = 4096;  // the smallest streamed batch

  /// Throws RenderInputError when `gpuBudgetBytes` is below minimumBytes().
  TetResidency(const Gl& gl, std::shared_ptr<const TetMeshSource> source, size_t gpuBudgetBytes);
  ~TetResidency();

  const TetMeshSource& source() const { return *mSource; }
  /// Holds `data` as the frame's tets. True when they are not the tets on the GPU: how they are held is decided
  /// anew (streamed, batchTets), the ray caster's copy dropped, and the caller uploads them and calls uploaded().
  bool hold(std::shared_ptr<const TetMeshData> data);
  /// The tets on the GPU are those held.
  void uploaded() { mUploaded = mData->id; }
  /// A paged mesh's working set dropped when a frame is done with it (its GPU copy stays, known by its id).
  void release();
  /// The tets held.
  const TetMeshData& data() const { return *mData; }

  /// Whether the projected tets are streamed in batches each frame (the mesh is larger than the budget).
  bool streamed() const { return mStreamed; }
  /// Tets the projected vertex buffer holds: all of them, or a streamed batch.
  size_t batchTets() const { return mBatchTets; }
  /// The ray caster of the tets held, when they are resident and its buffers fit the budget beside the projected
  /// tets' (made on first use); null otherwise.
  TetRayCaster* rayCaster();
  size_t gpuBytes() const;

  /// The GPU bytes a mesh of `tets` tetrahedra takes resident: its vertices, its order and the table.
  static size_t bytesFor(size_t tets);
  /// The least budget a renderer works in: the table and a batch of kMinBatchTets.
  static size_t minimumBytes();
  /// The largest pre-integration table (64 length layers of RGBA32F).
  static size_t tableBytes();

 private:
  const Gl& mGl;
  std::shared_ptr<const TetMeshSource> mSource;
  std::shared_ptr<const TetMeshData> mData;  // the tets on the GPU; a paged mesh's only while a frame draws them
  uint64_t mUploaded = 0;                    // the id (TetMeshData::id) of the tets on the GPU; 0 for none
  size_t mGpuBudget = 0;
  bool mStreamed = false;
  size_t mBatchTets = 0;
  std::unique_ptr<TetRayCaster> mRayCaster;  // made by the first frame that ray casts
};

}  // namespace voxbrick::render
