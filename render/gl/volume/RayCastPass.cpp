// Filling the cell table batch by batch and drawing each batch as one full-screen ray-casting pass, in bands.
#include "render/gl/volume/RayCastPass.h"

#include <algorithm>
#include <chrono>

#include "render/core/FrameStats.h"
#include "render/gl/volume/ComputeRayCast.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

double RayCastPass::samplesPerPixel(const FramePlan& plan, double samplesEstimated) {
  // Pixels near the middle take more than the frame's mean: three times the mean, at most a ray through the whole
  // volume's diagonal at every plane.
  const double pixels = std::max(1.0, double(plan.width) * plan.height);
  const double longest = glm::length(plan.volume.extent()) / std::max(plan.step, 1e-12) + 1;
  return std::min(3 * samplesEstimated / pixels, longest);
}

RayCastPass::RayCastPass(const Gl& gl)
    : mGl(gl), mCells(gl), mRequests(gl), mTermination(gl), mCounters(gl), mNoAttributes(gl) {}

void RayCastPass::finish(FrameStats& stats) {
  mCounters.read(stats);
  if (!mRequesting) return;
  mRequests.read(stats);
  // Stand-ins a ray reached: what makes the frame differ from the octree mode's (FrameStats::bricksStandIn 0 means
  // exact). Those no ray reached change no pixel.
  stats.bricksStandIn = int64_t(mRequests.standIns().size()) - stats.bricksUntouched;
}

void RayCastPass::draw(const FramePlan& plan, Residency& residency, const VolumeProgram& program,
                       const SliceGeometry& planes, Compositor& compositor, FrameStats& stats,
                       Checkpoints& checkpoints, bool keepTable) {
  mBatchesDrawn = 0;
  mCounters.reset();
  mSamplesPerPixel = checkpoints.intervalSamples() > 0 ? samplesPerPixel(plan, stats.samplesEstimated) : 0;
  mRequesting = plan.rayResidency && keepTable && KeptCells::fits(plan, residency);
  if (mRequesting) mRequests.begin(residency.store(), program);
  if (keepTable && KeptCells::fits(plan, residency)) {
    // One batch: the table kept from the last frame, changed where the bricks changed.
    const bool any = mKept.update(plan, residency, mCells, stats, checkpoints, mRequesting ? &mRequests : nullptr);
    program.setCells(mCells.cells(), mCells.shift());
    if (any) march(plan, program, compositor, stats, checkpoints);
    residency.endBatch();
    return;
  }
  mKept.forget();
  mRequests.forget();
  stats.cellBricksChanged = -1;
  const store::StoreMeta& meta = residency.store().meta();
  mCells.begin(glm::ivec3(meta.dims.x, meta.dims.y, meta.dims.z), plan.cellSize, plan.pagedCells);
  // More bricks than slots: several batches (an upper bound: stand-ins may share a source).
  if (plan.visible.bricks.size() > size_t(residency.atlas().capacity()))
    mCells.deferAll(plan.visible, residency.store().brickSize());
  if (plan.part)
    mCells.deferOutside(glm::ivec3(plan.part->lo[0], plan.part->lo[1], plan.part->lo[2]),
                        glm::ivec3(plan.part->hi[0], plan.part->hi[1], plan.part->hi[2]));
  program.setCells(mCells.cells(), mCells.shift());
  auto add = [&](const QueuedBox& b) { mCells.add(b); };
  auto flush = [&] {
    if (mCells.empty()) return;
    const auto t = Clock::now();
    stats.cellsSent += mCells.upload();
    stats.msSlicing += msSince(t);
    march(plan, program, compositor, stats, checkpoints);
  };
  mWalk.run(plan, residency, planes, stats, checkpoints, add, flush);
  stats.slices = 0;  // the walk counts planes through boxes for slicing and slabs; rays take no slices
}

void RayCastPass::march(const FramePlan& plan, const VolumeProgram& program, Compositor& compositor,
                        FrameStats& stats, Checkpoints& checkpoints) {
  auto t = Clock::now();
  if (plan.ert > 0 && mBatchesDrawn > 0 && !program.compute()) mTermination.run(plan.ert, compositor);
  stats.msSlicing += msSince(t);
  t = Clock::now();
  if (program.compute()) {
    dispatchRayCast(mGl, program, compositor, plan.width, plan.height, checkpoints, mSamplesPerPixel);
  } else {
    program.program().use();
    mNoAttributes.bind();
    drawInBands(mGl, plan.width, plan.height, checkpoints, mSamplesPerPixel);
  }
  ++mBatchesDrawn;
  stats.batches += 1;
  stats.msDrawing += msSince(t);
}

}  // namespace voxbrick::render
