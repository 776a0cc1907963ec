// Keeping the cell table between frames of one batch: the frame's bricks compared with the table's, the difference
// applied.
#include "render/gl/volume/KeptCells.h"

#include <algorithm>
#include <chrono>

#include "render/core/RenderErrors.h"
#include "render/gl/Bindings.h"
#include "render/gl/volume/BrickWalk.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

bool KeptCells::fits(const FramePlan& plan, const Residency& residency) {
  return !plan.part && plan.visible.bricks.size() <= size_t(residency.atlas().capacity());
}

void KeptCells::clearRecords() {
  mRecords.clear();
  mBoxes = mSubBlocksSkipped = mDrawing = 0;
}

bool KeptCells::update(const FramePlan& plan, Residency& residency, CellTable& cells, FrameStats& stats,
                       const Checkpoints& checkpoints, RayRequests* requests) {
  const store::StoreMeta& meta = residency.store().meta();
  const int B = residency.store().brickSize();
  const glm::ivec3 dims(meta.dims.x, meta.dims.y, meta.dims.z);
  if (!mValid || plan.subBlock != mSubBlock || plan.classification != mClassification) cells.drop();
  const bool same = cells.resume(dims, plan.cellSize, plan.pagedCells);
  if (!same) {
    clearRecords();
    mSubBlock = plan.subBlock;
    mClassification = plan.classification;
  }
  mValid = false;  // until the table is the frame's: a frame given up part way leaves it to be built anew
  ++mFrame;
  int64_t changed = 0;
  // With ray-driven residency the table changes whenever the last frame's rays requested bricks (they are paged
  // now), and whenever the residency mode changed (the octree mode draws the bricks the rays left to stand-ins).
  const bool rays = requests != nullptr;
  if (!same || !residency.unchanged() || (requests && requests->any()) || rays != mRays) {
    mRays = rays;
    // Which bricks are drawn as the table holds them: the same stand-in, from the same slot. The others' cells are
    // cleared (those gone), then marked (those new or moved), once every brick is resident for the frame.
    auto t = Clock::now();
    mPending.clear();
    const store::BrickStore& store = residency.store();
    const int lastLevel = store.levelCount() - 1;
    const int standInLevel = requests ? RayRequests::standInLevel(store) : 0;
    if (requests) {
      // The requested bricks this frame pages, front to back (nearest first), decoded ahead by the cache's workers.
      requests->standIns().clear();
      mWanted.clear();
      for (const BrickDraw& draw : plan.visible.bricks)
        if (int64_t(mWanted.size()) < RayRequests::kPagesPerFrame && !residency.resident(draw.key) &&
            requests->requested(draw.key))
          mWanted.push_back(draw.key);
      residency.prefetch(mWanted);
    }
    int64_t paging = 0;
    for (BrickDraw draw : plan.visible.bricks) {
      checkpoints.poll();
      bool flagged = false;
      if (requests && int(draw.key.level) < lastLevel && !residency.resident(draw.key)) {
        if (paging < RayRequests::kPagesPerFrame && requests->requested(draw.key)) {
          ++paging;
        } else {
          // Drawn from its nearest resident ancestor below the stand-in level, else from that level's (paged now).
          const int top = std::min(lastLevel, std::max(standInLevel, int(draw.key.level) + 1));
          draw.standIn = 1;
          while (int(draw.key.level + draw.standIn) < top && !residency.resident(draw.source())) ++draw.standIn;
          flagged = true;
          requests->standIns().push_back(draw.key);
        }
      }
      const auto resident = residency.acquire(draw.source(), plan.subBlock, stats);
      if (!resident) throw RenderError("ray casting: the atlas cannot hold the frame's bricks at once");
      glm::ivec4 payload = brickPayload(draw, *resident, B);
      if (flagged) payload.w += VB_REQUEST_FLAG;
      const auto it = mRecords.find(draw.key);
      if (it != mRecords.end() && it->second.standIn == draw.standIn && it->second.payload == payload)
        it->second.frame = mFrame;
      else
        mPending.push_back({draw, flagged, *resident, payload});
    }
    stats.msPaging += msSince(t);
    t = Clock::now();
    const auto clearBrick = [&](const store::BrickKey& key) {
      const glm::ivec3 lo = glm::ivec3(int(key.i), int(key.j), int(key.k)) * (B << key.level);
      cells.clear(lo, glm::min(lo + (B << key.level), dims));
    };
    for (auto it = mRecords.begin(); it != mRecords.end();) {
      if (it->second.frame == mFrame) {
        ++it;
        continue;
      }
      // Gone, or drawn otherwise this frame (marked again below, from what its cells hold now).
      clearBrick(it->first);
      mBoxes -= it->second.boxes, mSubBlocksSkipped -= it->second.subBlocksSkipped;
      mDrawing -= it->second.boxes > 0;
      it = mRecords.erase(it);
    }
    for (const Pending& p : mPending) {
      const BrickDraw& draw = p.draw;
      SubBlockWalkStats sub;
      if (p.flagged) {
        // Every voxel the brick owns: where its stand-in's sub-blocks are empty the brick's own may not be, and a
        // ray must reach its cells to request it.
        const store::BrickKey& key = draw.key;
        const int64_t side = int64_t(B) << key.level;
        const store::Vec3i lo{int64_t(key.i) * side, int64_t(key.j) * side, int64_t(key.k) * side};
        mSpans.assign(1,
                      VoxelSpan{lo, store::Vec3i{std::min(lo.x + side, meta.dims.x), std::min(lo.y + side, meta.dims.y),
                                                 std::min(lo.z + side, meta.dims.z)}});
        sub.boxes = 1;
      } else {
        brickSpans(plan, draw, p.resident, meta, B, mSpans, sub);
      }
      QueuedBox box;
      box.payload = p.payload;
      for (const VoxelSpan& span : mSpans) {
        box.ownLo = glm::ivec3(span.lo.x, span.lo.y, span.lo.z);
        box.ownHi = glm::ivec3(span.hi.x, span.hi.y, span.hi.z);
        cells.add(box);
      }
      const int64_t boxes = plan.subBlock ? sub.boxes : 1;
      mRecords[draw.key] = {draw.standIn, p.payload, boxes, sub.subBlocksSkipped, mFrame};
      mBoxes += boxes, mSubBlocksSkipped += sub.subBlocksSkipped;
      mDrawing += boxes > 0;
    }
    changed = int64_t(mPending.size());
    stats.msSlicing += msSince(t);
  }
  const auto t = Clock::now();
  stats.cellsSent = cells.uploadChanges();
  stats.msSlicing += msSince(t);
  stats.cellBricksChanged = changed;
  stats.boxesDrawn = mBoxes;
  stats.subBlocksSkipped = mSubBlocksSkipped;
  mValid = true;
  return mDrawing > 0;
}

}  // namespace voxbrick::render
