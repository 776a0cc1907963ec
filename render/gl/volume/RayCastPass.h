// The frame ray caster: for each batch of bricks the atlas holds at once, the cell table (render/gl/volume/CellTable.h)
// is filled with the batch's boxes and one fragment per pixel marches its ray through the whole batch, finding each
// sample's brick in the table (volume_march.glsl; raycast.frag.glsl, or the compute kernel raycast.comp.glsl
// dispatched by render/gl/volume/ComputeRayCast.h, Scene::raycaster). Where texture slabs draw a proxy per box and slab and
// blend once per box, the ray caster draws one full-screen triangle and blends once per pixel and batch: no box
// geometry, no fragment per box, a ray that stops at the termination threshold stops for the whole batch.
//
// The samples are the global planes' points that slicing and slabs take, owned as slabs own them, so the image is
// the same beyond round-off. Batches are taken front to back along the bricks' visibility order, which every ray
// follows, so compositing batch after batch is compositing along each ray; between batches the silhouette map
// (render/gl/volume/TerminationPass.h) keeps terminated pixels from being marched again (the compute kernel reads
// each pixel's opacity itself and needs none). The frame is drawn in bands of rows, so that a cancelled frame stops
// within a band (render/gl/Checkpoints.h). A frame of one batch keeps its table
// from the last frame and changes it where the bricks changed (render/gl/volume/KeptCells.h).
#pragma once

#include "render/gl/Bands.h"
#include "render/gl/Compositor.h"
#include "render/gl/SampleCounters.h"
#include "render/gl/volume/CellTable.h"
#include "render/gl/volume/KeptCells.h"
#include "render/gl/volume/RayRequests.h"
#include "render/gl/volume/SlicingPass.h"
#include "render/gl/volume/TerminationPass.h"

namespace voxbrick::render {

class RayCastPass {
 public:
  explicit RayCastPass(const Gl& gl);

  /// Draws plan.visible with `program` (a ray caster variant) into `compositor`'s target, which begin() set up with a
  /// silhouette map iff plan.ert > 0. `planes` gives the planes through a box (boxes with none are left out).
  /// `keepTable`: a frame of one batch draws from the table kept from the last frame (KeptCells), else every
  /// batch's table is filled anew. plan.rayResidency (which needs the kept table; VolumeRenderer ensures it): the rays
  /// decide what is paged (RayRequests), and `program` is a RAY_REQUESTS variant.
  void draw(const FramePlan& plan, Residency& residency, const VolumeProgram& program, const SliceGeometry& planes,
            Compositor& compositor, FrameStats& stats, Checkpoints& checkpoints, bool keepTable = true);
  /// After the compositor's finish: fragments started, samples taken and left by termination into `stats`.
  /// With ray-driven residency (plan.rayResidency), also reads back the rays' requests (RayRequests::read).
  void finish(FrameStats& stats);
  /// The cell table the last batch was drawn with (for tests: CellTable::readBack).
  const CellTable& cells() const { return mCells; }

 private:
  /// The most samples a pixel of one pass may take, for sizing bands by cost (drawInBands), from the frame's
  /// estimate (FramePlan::estimatedSamples, already in FrameStats::samplesEstimated).
  static double samplesPerPixel(const FramePlan& plan, double samplesEstimated);
  /// Marches every pixel's ray through the batch whose cell table is bound (after marking terminated pixels in the
  /// silhouette map when an earlier batch was drawn).
  void march(const FramePlan& plan, const VolumeProgram& program, Compositor& compositor, FrameStats& stats,
             Checkpoints& checkpoints);

  const Gl& mGl;
  BrickWalk mWalk;
  CellTable mCells;
  KeptCells mKept;
  RayRequests mRequests;
  bool mRequesting = false;  // this frame's rays record requests
  TerminationPass mTermination;
  SampleCounters mCounters;
  VertexArray mNoAttributes;
  int mBatchesDrawn = 0;        // this frame's
  double mSamplesPerPixel = 0;  // this frame's, 0 when the bands are not sized by cost
};

}  // namespace voxbrick::render
