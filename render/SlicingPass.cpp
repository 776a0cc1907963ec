// Slicing bricks front to back, batch by batch.
#include "render/SlicingPass.h"

#include <algorithm>
#include <chrono>

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

void drawBatch(const VolumeProgram& program, SliceGeometry& geometry, FrameStats& stats) {
  if (geometry.empty()) return;
  const auto t = Clock::now();
  program.program().use();
  geometry.draw();
  stats.batches += 1;
  stats.msDrawing += msSince(t);
}

}  // namespace

void SlicingPass::draw(const FramePlan& plan, Residency& residency, const VolumeProgram& program,
                       SliceGeometry& geometry, FrameStats& stats) {
  const store::StoreMeta& meta = residency.store().meta();
  const int B = residency.store().brickSize();
  mSubStats = {};
  for (const BrickDraw& brick : plan.visible.bricks) {
    auto t = Clock::now();
    const PlaneIndexRange brickPlanes = geometry.planes(plan.drawBox(brick.box, meta.spacing), plan);
    stats.msSlicing += msSince(t);
    if (brickPlanes.count() == 0) continue;

    // Page and slice brick by brick; draw whenever the atlas is full of this batch's bricks.
    t = Clock::now();
    auto resident = residency.acquire(brick.key, plan.subBlock, stats);
    if (!resident) {
      stats.msPaging += msSince(t);
      drawBatch(program, geometry, stats);
      residency.endBatch();
      t = Clock::now();
      resident = residency.acquire(brick.key, plan.subBlock, stats);
    }
    stats.msPaging += msSince(t);

    t = Clock::now();
    queueBrick(plan, brick, *resident, brickPlanes, meta, B, geometry, stats);
    stats.msSlicing += msSince(t);
  }
  stats.subBlocksSkipped = mSubStats.subBlocksSkipped;
  stats.boxesDrawn = plan.subBlock ? mSubStats.boxes : stats.bricksDrawn;
  drawBatch(program, geometry, stats);
  residency.endBatch();
}

void SlicingPass::queueBrick(const FramePlan& plan, const BrickDraw& draw, const Residency::Resident& resident,
                             const PlaneIndexRange& brickPlanes, const store::StoreMeta& meta, int brickSize,
                             SliceGeometry& geometry, FrameStats& stats) {
  const store::BrickKey& key = draw.key;
  const store::Vec3i brickLo{int64_t(key.i) * brickSize, int64_t(key.j) * brickSize, int64_t(key.k) * brickSize};
  const store::Vec3i brickHi{std::min<int64_t>(brickLo.x + brickSize, meta.dims.x),
                             std::min<int64_t>(brickLo.y + brickSize, meta.dims.y),
                             std::min<int64_t>(brickLo.z + brickSize, meta.dims.z)};
  mSpans.clear();
  if (plan.subBlock)
    subBlockBoxes(*resident.ranges, brickLo, meta.dims, meta.spacing, plan.camera, plan.contributes, mSpans, mSubStats);
  else
    mSpans.push_back({brickLo, brickHi});
  const glm::ivec4 payload(resident.origin.x + 1 - int32_t(brickLo.x), resident.origin.y + 1 - int32_t(brickLo.y),
                           resident.origin.z + 1 - int32_t(brickLo.z), 0);
  // Whole bricks own the whole volume (only the outline is cut, the same for every bricking); with exact ownership
  // (sub-blocks, slabs) each box owns just its voxels (volume.frag.glsl).
  const glm::ivec3 volumeHi(meta.dims.x, meta.dims.y, meta.dims.z);
  for (const VoxelSpan& span : mSpans) {
    const Box box = plan.drawBox(voxelSpanBox(span.lo, span.hi, meta.dims, meta.spacing), meta.spacing);
    const PlaneIndexRange planes = plan.subBlock ? geometry.planes(box, plan) : brickPlanes;
    if (planes.count() == 0) continue;
    const bool exact = plan.exactOwnership();
    const glm::ivec3 ownLo = exact ? glm::ivec3(span.lo.x, span.lo.y, span.lo.z) : glm::ivec3(0);
    const glm::ivec3 ownHi = exact ? glm::ivec3(span.hi.x, span.hi.y, span.hi.z) : volumeHi;
    stats.slices += planes.count();
    geometry.add(box, planes, payload, ownLo, ownHi, plan);
  }
}

}  // namespace voxbrick::render
