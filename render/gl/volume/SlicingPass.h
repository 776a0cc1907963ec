// View-aligned slicing: every box of a batch (BrickWalk) sliced by the global planes, one blended sample per
// fragment. Texture slabs are render/gl/volume/SlabPass.h, the frame ray caster render/gl/volume/RayCastPass.h.
#pragma once

#include "render/gl/volume/BrickWalk.h"
#include "render/gl/volume/VolumePrograms.h"

namespace voxbrick::render {

class SlicingPass {
 public:
  /// Draws every brick of `plan.visible` with `program` through `geometry`, paging through `residency`. Fills the
  /// slicing, paging and drawing counters and times of `stats`. Paces `checkpoints` after each batch.
  void draw(const FramePlan& plan, Residency& residency, const VolumeProgram& program, SliceGeometry& geometry,
            FrameStats& stats, Checkpoints& checkpoints);

 private:
  BrickWalk mWalk;
};

}  // namespace voxbrick::render
