// The drawing technique of today: view-aligned slicing. Bricks (or, with sub-blocks, the boxes a brick is drawn
// as) are sliced by the global planes, front to back, one blended sample per fragment, in batches of what the atlas
// holds at once. Texture slabs will be a second pass beside this one.
#pragma once

#include <vector>

#include "render/FramePlan.h"
#include "render/Residency.h"
#include "render/SliceGeometry.h"
#include "render/SubBlocks.h"
#include "render/VolumePrograms.h"

namespace voxbrick::render {

class SlicingPass {
 public:
  /// Draws every brick of `plan.visible` with `program` through `geometry`, paging through `residency`. Fills the
  /// slicing, paging and drawing counters and times of `stats`.
  void draw(const FramePlan& plan, Residency& residency, const VolumeProgram& program, SliceGeometry& geometry,
            FrameStats& stats);

 private:
  /// Queues brick `draw` (resident as `resident`) as its boxes.
  void queueBrick(const FramePlan& plan, const BrickDraw& draw, const Residency::Resident& resident,
                  const PlaneIndexRange& brickPlanes, const store::StoreMeta& meta, int brickSize,
                  SliceGeometry& geometry, FrameStats& stats);

  std::vector<VoxelSpan> mSpans;
  SubBlockWalkStats mSubStats;
};

}  // namespace voxbrick::render
