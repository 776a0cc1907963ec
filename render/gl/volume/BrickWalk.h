// Walking a frame's bricks for the drawing passes: page plan.visible front to back in batches of what the atlas holds
// at once, and cut each brick into the boxes it is drawn as. Every drawing pass (slicing, slabs, ray casting) uses it.
#pragma once

#include <functional>
#include <vector>

#include "render/gl/Checkpoints.h"
#include "render/gl/volume/Residency.h"
#include "render/gl/volume/SliceGeometry.h"
#include "render/volume/FramePlan.h"
#include "render/volume/SubBlocks.h"

namespace voxbrick::render {

/// One box to draw: its drawn (enlarged) world box, the global planes through it, the atlas payload and the voxels
/// it owns [ownLo, ownHi) (volume_ownership.glsl).
struct QueuedBox {
  Box box;
  PlaneIndexRange planes;
  glm::ivec4 payload;
  glm::ivec3 ownLo, ownHi;
};

/// The atlas payload of `draw`'s boxes, `resident` its source in the atlas: xyz added to a sample's voxel coordinate
/// in the source's level gives its atlas texel, w the level and the rotation (payloadLevel).
glm::ivec4 brickPayload(const BrickDraw& draw, const Residency::Resident& resident, int brickSize);

/// The level-0 voxels each box of `draw` owns, front to back, into `spans` (cleared first): the voxels the brick
/// owns, or with sub-blocks those of its sub-blocks the transfer function keeps (counted into `stats`), cut to the
/// plan's part if it has one (nothing left when the part misses the brick). Returns whether the part cut it.
bool brickSpans(const FramePlan& plan, const BrickDraw& draw, const Residency::Resident& resident,
                const store::StoreMeta& meta, int brickSize, std::vector<VoxelSpan>& spans, SubBlockWalkStats& stats);

/// Pages plan.visible front to back and cuts each brick into its boxes (whole bricks, or with sub-blocks the boxes
/// of its non-empty sub-blocks), in visibility order.
class BrickWalk {
 public:
  /// Hands every box to `add`, in visibility order; calls `flush` when the atlas is full of the current batch's
  /// bricks (the batch is then ended) and once at the end. `geometry` gives the planes through a box. Fills the
  /// slicing, paging, sub-block and box counters of `stats`. Polls `checkpoints` before each brick.
  void run(const FramePlan& plan, Residency& residency, const SliceGeometry& geometry, FrameStats& stats,
           const Checkpoints& checkpoints, const std::function<void(const QueuedBox&)>& add,
           const std::function<void()>& flush);

 private:
  void cutBrick(const FramePlan& plan, const BrickDraw& draw, const Residency::Resident& resident,
                const PlaneIndexRange& brickPlanes, const store::StoreMeta& meta, int brickSize,
                const SliceGeometry& geometry, FrameStats& stats, const std::function<void(const QueuedBox&)>& add);

  std::vector<VoxelSpan> mSpans;
  SubBlockWalkStats mSubStats;
};

}  // namespace voxbrick::render
