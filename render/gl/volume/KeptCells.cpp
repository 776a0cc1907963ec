// Keeping the cell table between frames of one batch: the frame's bricks compared with the table's, the difference
// applied.
#include "render/gl/volume/KeptCells.h"

#include <algorithm>
#include <chrono>

#include "render/core/RenderErrors.h"
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
                       const Checkpoints& checkpoints) {
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
  if (!same || !residency.unchanged()) {
    // Which bricks are drawn as the table holds them: the same stand-in, from the same slot. The others' cells are
    // cleared (those gone), then marked (those new or moved), once every brick is resident for the frame.
    auto t = Clock::now();
    mPending.clear();
    for (size_t i = 0; i < plan.visible.bricks.size(); ++i) {
      const BrickDraw& draw = plan.visible.bricks[i];
      checkpoints.poll();
      const auto resident = residency.acquire(draw.source(), plan.subBlock, stats);
      if (!resident) throw RenderError("ray casting: the atlas cannot hold the frame's bricks at once");
      const glm::ivec4 payload = brickPayload(draw, *resident, B);
      const auto it = mRecords.find(draw.key);
      if (it != mRecords.end() && it->second.standIn == draw.standIn && it->second.payload == payload)
        it->second.frame = mFrame;
      else
        mPending.push_back({i, *resident, payload});
    }
    stats.msPaging += msSince(t);
    t = Clock::now();
    for (auto it = mRecords.begin(); it != mRecords.end();) {
      if (it->second.frame == mFrame) {
        ++it;
        continue;
      }
      const store::BrickKey& key = it->first;
      const glm::ivec3 lo = glm::ivec3(int(key.i), int(key.j), int(key.k)) * (B << key.level);
      cells.clear(lo, glm::min(lo + (B << key.level), dims));
      mBoxes -= it->second.boxes, mSubBlocksSkipped -= it->second.subBlocksSkipped;
      mDrawing -= it->second.boxes > 0;
      it = mRecords.erase(it);
    }
    for (const Pending& p : mPending) {
      const BrickDraw& draw = plan.visible.bricks[p.draw];
      SubBlockWalkStats sub;
      brickSpans(plan, draw, p.resident, meta, B, mSpans, sub);
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
