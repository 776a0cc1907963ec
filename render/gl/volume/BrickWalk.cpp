// Walking bricks front to back, batch by batch, and cutting each into its boxes.
#include "render/gl/volume/BrickWalk.h"

#include <algorithm>
#include <chrono>

#include "render/core/FrameStats.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;

// Cuts `span` to [lo, hi); false when nothing is left.
bool clipSpan(VoxelSpan& span, const store::Vec3i& lo, const store::Vec3i& hi) {
  span.lo = {std::max(span.lo.x, lo.x), std::max(span.lo.y, lo.y), std::max(span.lo.z, lo.z)};
  span.hi = {std::min(span.hi.x, hi.x), std::min(span.hi.y, hi.y), std::min(span.hi.z, hi.z)};
  return span.lo.x < span.hi.x && span.lo.y < span.hi.y && span.lo.z < span.hi.z;
}

}  // namespace

void BrickWalk::run(const FramePlan& plan, Residency& residency, const SliceGeometry& geometry, FrameStats& stats,
                    const Checkpoints& checkpoints, const std::function<void(const QueuedBox&)>& add,
                    const std::function<void()>& flush) {
  const store::StoreMeta& meta = residency.store().meta();
  const int B = residency.store().brickSize();
  mSubStats = {};
  for (const BrickDraw& brick : plan.visible.bricks) {
    checkpoints.poll();
    auto t = Clock::now();
    const PlaneIndexRange brickPlanes = geometry.planes(plan.drawBox(brick.box, meta.spacing), plan);
    stats.msSlicing += msSince(t);
    if (brickPlanes.count() == 0) continue;

    // Page and cut brick by brick; draw whenever the atlas is full of this batch's bricks.
    t = Clock::now();
    auto resident = residency.acquire(brick.source(), plan.subBlock, stats);
    if (!resident) {
      stats.msPaging += msSince(t);
      flush();
      residency.endBatch();
      t = Clock::now();
      resident = residency.acquire(brick.source(), plan.subBlock, stats);
    }
    stats.msPaging += msSince(t);

    t = Clock::now();
    cutBrick(plan, brick, *resident, brickPlanes, meta, B, geometry, stats, add);
    stats.msSlicing += msSince(t);
  }
  stats.subBlocksSkipped = mSubStats.subBlocksSkipped;
  stats.boxesDrawn = plan.subBlock ? mSubStats.boxes : int64_t(plan.visible.bricks.size());
  flush();
  residency.endBatch();
}

glm::ivec4 brickPayload(const BrickDraw& draw, const Residency::Resident& resident, int brickSize) {
  // xyz: added to a sample's voxel coordinate in the brick's level (rotated as the brick is in its slot), gives
  // its atlas texel: slot origin + 1 + rotated(v - brickLo); w: the level and the rotation (payloadLevel).
  const store::BrickKey source = draw.source();
  const glm::ivec3 brickLo = glm::ivec3(int(source.i), int(source.j), int(source.k)) * brickSize;
  return {resident.origin + 1 - orientVoxel(brickLo, resident.orientation),
          payloadLevel(int(source.level), resident.orientation)};
}

bool brickSpans(const FramePlan& plan, const BrickDraw& draw, const Residency::Resident& resident,
                const store::StoreMeta& meta, int brickSize, std::vector<VoxelSpan>& spans, SubBlockWalkStats& stats) {
  // The voxels the brick owns, in level 0's (a level-m voxel is 2^m across); the first voxel of the brick its
  // samples come from (itself, or a stand-in ancestor), in that brick's level.
  spans.clear();
  const store::BrickKey& key = draw.key;
  const int keyLevel = int(key.level);
  const store::Vec3i ownedLo{int64_t(key.i) * brickSize << keyLevel, int64_t(key.j) * brickSize << keyLevel,
                             int64_t(key.k) * brickSize << keyLevel};
  store::Vec3i ownedHi{std::min<int64_t>(ownedLo.x + (int64_t(brickSize) << keyLevel), meta.dims.x),
                       std::min<int64_t>(ownedLo.y + (int64_t(brickSize) << keyLevel), meta.dims.y),
                       std::min<int64_t>(ownedLo.z + (int64_t(brickSize) << keyLevel), meta.dims.z)};
  // A part's frame (sort-last rendering) draws only the voxels inside the part: the brick is cut to it.
  VoxelSpan owned{ownedLo, ownedHi};
  bool cut = false;
  if (plan.part) {
    const PartBox& part = *plan.part;
    const VoxelSpan whole = owned;
    if (!clipSpan(owned, {part.lo[0], part.lo[1], part.lo[2]}, {part.hi[0], part.hi[1], part.hi[2]})) return false;
    cut = !(owned.lo == whole.lo && owned.hi == whole.hi);
  }
  if (!plan.subBlock) {
    spans.push_back(owned);
    return cut;
  }
  const store::BrickKey source = draw.source();
  const store::Vec3i brickLo{int64_t(source.i) * brickSize, int64_t(source.j) * brickSize,
                             int64_t(source.k) * brickSize};
  subBlockBoxes(*resident.ranges, brickLo, int(source.level), meta.dims, meta.spacing, plan.camera, plan.contributes,
                spans, stats);
  // A stand-in's sub-blocks cover its whole brick: keep their parts inside the voxels this draw owns. Clipping
  // to a box keeps the spans' front-to-back order.
  if (draw.standIn > 0 || cut)
    std::erase_if(spans, [&](VoxelSpan& span) { return !clipSpan(span, owned.lo, owned.hi); });
  return cut;
}

void BrickWalk::cutBrick(const FramePlan& plan, const BrickDraw& draw, const Residency::Resident& resident,
                         const PlaneIndexRange& brickPlanes, const store::StoreMeta& meta, int brickSize,
                         const SliceGeometry& geometry, FrameStats& stats,
                         const std::function<void(const QueuedBox&)>& add) {
  const bool cut = brickSpans(plan, draw, resident, meta, brickSize, mSpans, mSubStats);
  const glm::ivec4 payload = brickPayload(draw, resident, brickSize);
  // Whole bricks own the whole volume (only the outline is cut, the same for every bricking); with exact ownership
  // (sub-blocks, slabs) each box owns just its voxels (volume_ownership.glsl).
  const glm::ivec3 volumeHi(meta.dims.x, meta.dims.y, meta.dims.z);
  const bool exact = plan.exactOwnership();
  for (const VoxelSpan& span : mSpans) {
    QueuedBox queued;
    queued.box = plan.drawBox(voxelSpanBox(span.lo, span.hi, meta.dims, meta.spacing), meta.spacing);
    queued.planes = plan.subBlock || cut ? geometry.planes(queued.box, plan) : brickPlanes;
    if (queued.planes.count() == 0) continue;
    queued.payload = payload;
    queued.ownLo = exact ? glm::ivec3(span.lo.x, span.lo.y, span.lo.z) : glm::ivec3(0);
    queued.ownHi = exact ? glm::ivec3(span.hi.x, span.hi.y, span.hi.z) : volumeHi;
    stats.slices += queued.planes.count();
    add(queued);
  }
}

}  // namespace voxbrick::render
