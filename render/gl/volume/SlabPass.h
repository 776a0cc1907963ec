// Texture slabs (Yalım 2005, chapter 4), drawn slab by slab. A slab is N consecutive global planes; for
// each slab, front to back, every box of the batch that the slab crosses is drawn once (its back faces,
// slab.vert.glsl) and the fragment program marches its pixel's ray through the slab's planes inside the box,
// compositing in registers and blending once (slab.frag.glsl). The samples are the global planes' points
// either way, so the image does not depend on N beyond round-off.
//
// Early ray termination (Scene::ert) uses a slab silhouette map in the target's depth buffer (Compositor): slab
// fragments lie at depth 1/2 and are tested GL_LESS; after each slab a pass over the accumulated colour writes depth
// 0 where its opacity reached the threshold, so the early depth test rejects those pixels' fragments in every later
// slab. Within one batch of the atlas the order is slab-major, across batches brick order: both are visibility
// orders along every ray (bricks are convex and drawn front to back; a ray crosses the planes in order).
//
// Empty-space silhouette maps (Scene::ess, Yalım's CSSM pass): each slab's fragments get their own depth,
// 1 - k * 2^-22 for the frame's k-th slab, decreasing. Before slab k is marched, the same boxes are drawn with the
// EMPTY_TEST program, colour off, depth written (GL_LESS) only where some sample (or pre-integrated segment) of the
// slab has opacity; the march then tests GL_EQUAL, so it runs only on those pixels. Terminated pixels hold 0 and
// fail both tests.
#pragma once

#include <vector>

#include "render/gl/Compositor.h"
#include "render/gl/SampleCounters.h"
#include "render/gl/volume/SlicingPass.h"
#include "render/gl/volume/TerminationPass.h"

namespace voxbrick::render {

class SlabPass {
 public:
  explicit SlabPass(const Gl& gl);

  /// Draws plan.visible as slabs of plan.slab planes with `program` (a slab variant) into `compositor`'s target,
  /// which begin() set up with a silhouette map iff plan.ert > 0. Fills the counters and times of `stats` that the
  /// GPU does not (see finish).
  /// With plan.ess, `emptyTest` is the EMPTY_TEST variant of `program`.
  void draw(const FramePlan& plan, Residency& residency, const VolumeProgram& program, const VolumeProgram* emptyTest,
            SlabGeometry& geometry, Compositor& compositor, FrameStats& stats, Checkpoints& checkpoints);
  /// After the compositor's finish: the slab fragments' own counts (fragments started, samples taken and left by
  /// termination) into `stats`.
  void finish(FrameStats& stats) const;

 private:
  void drawBatch(const FramePlan& plan, const VolumeProgram& program, const VolumeProgram* emptyTest,
                 SlabGeometry& geometry, Compositor& compositor, FrameStats& stats, Checkpoints& checkpoints);

  const Gl& mGl;
  BrickWalk mWalk;
  std::vector<QueuedBox> mBoxes;  // the current batch's boxes, in visibility order
  TerminationPass mTermination;
  SampleCounters mCounters;
  int64_t mSlabsDrawn = 0;  // this frame's, for the empty-space maps' depths
};

}  // namespace voxbrick::render
