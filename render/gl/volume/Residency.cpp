// Paging bricks into the atlas, with prefetch and sub-block ranges.
#include "render/gl/volume/Residency.h"

#include <algorithm>
#include <span>

namespace voxbrick::render {
namespace {

constexpr size_t kPrefetchWindow = 256;  // bricks decoded ahead of the one being paged

}  // namespace

Residency::Residency(const GlContext& context, std::shared_ptr<store::BrickCache> cache, size_t gpuBudgetBytes,
                     AtlasFormat format, AtlasUploads uploads, AtlasBricking bricking)
    : mCache(std::move(cache)),
      mAtlas(context, mCache->store()->type(), mCache->store()->brickEdge(), gpuBudgetBytes,
             usefulSlots(*mCache->store()), format, uploads, bricking) {
  mSlotRanges.resize(size_t(mAtlas.slots().capacity()));
}

int64_t Residency::standIn(std::vector<BrickDraw>& bricks, int coarsest) {
  const auto ready = [&](const store::BrickKey& key) { return mAtlas.slots().resident(key) || mCache->ready(key); };
  const store::StoreMeta& meta = mCache->store()->meta();
  std::vector<store::BrickKey> missing;
  std::vector<BrickDraw> out;
  out.reserve(bricks.size());
  int64_t standIns = 0;
  for (BrickDraw d : bricks) {
    d.standIn = 0;
    if (int(d.key.level) < coarsest && !ready(d.key)) {
      // The queue keeps its newest requests when full, and the first bricks drawn are the ones wanted first.
      if (missing.size() < mCache->prefetchQueueLimit()) missing.push_back(d.key);
      d.standIn = 1;
      while (int(d.key.level + d.standIn) < coarsest && !ready(d.source())) ++d.standIn;
      ++standIns;
    }
    out.push_back(d);
    // Siblings are consecutive in the traversal's order: once every child of a node is drawn from the same
    // ancestor above it, the node is one box (the same voxels, the same samples, far fewer boxes on a cold start).
    while (out.back().standIn > 0) {
      const BrickDraw& last = out.back();
      const uint32_t level = last.key.level;
      const store::BrickKey parent{level + 1, last.key.i >> 1, last.key.j >> 1, last.key.k >> 1};
      const store::Vec3i& grid = meta.levels.at(level).bricks;
      const auto span = [](uint32_t p, int64_t n) { return 2 * int64_t(p) + 1 < n ? 2 : 1; };
      const size_t children = size_t(span(parent.i, grid.x) * span(parent.j, grid.y) * span(parent.k, grid.z));
      if (out.size() < children) break;
      Box box = last.box;
      bool whole = true;
      for (size_t c = out.size() - children; c < out.size() && whole; ++c) {
        const BrickDraw& s = out[c];
        whole = s.key.level == level && s.standIn == last.standIn && (s.key.i >> 1) == parent.i &&
                (s.key.j >> 1) == parent.j && (s.key.k >> 1) == parent.k;
        box.min = glm::min(box.min, s.box.min), box.max = glm::max(box.max, s.box.max);
      }
      if (!whole) break;
      const uint32_t standIn = last.standIn - 1;
      out.resize(out.size() - children);
      out.push_back({parent, box, standIn});
    }
  }
  bricks = std::move(out);
  mCache->prefetch(missing);
  return standIns;
}

int Residency::usefulSlots(const store::BrickStore& store) {
  return int(std::min<int64_t>(store.level(0).bricksTotal(), 1 << 20));
}

size_t Residency::atlasBytes(const store::BrickStore& store, size_t gpuBudgetBytes, AtlasFormat format,
                             AtlasUploads uploads) {
  const size_t staging = uploads == AtlasUploads::Staged
                             ? BrickAtlas::stagingBytes(store.type(), store.brickEdge(), gpuBudgetBytes, format)
                             : 0;
  const size_t slot = BrickAtlas::slotBytes(store.type(), store.brickEdge(), format);
  return std::min((gpuBudgetBytes - staging) / slot, size_t(usefulSlots(store))) * slot + staging;
}

void Residency::beginFrame(const std::vector<BrickDraw>& bricks, bool prefetch) {
  mToPage.clear();
  mPrefetched = mPaged = 0;
  // The same set of draws as the last frame: as many, each drawn by the last frame with the same stand-in (a frame
  // draws a key once). An array per level, not a hash: a few nanoseconds a brick.
  const store::StoreMeta& meta = mCache->store()->meta();
  if (mDrawn.empty())
    for (const store::LevelMeta& level : meta.levels) mDrawn.emplace_back(size_t(level.bricksTotal()));
  const uint32_t last = mFrame++;
  bool same = mEnded && mAtlas.slots().generation() == mEndGeneration && bricks.size() == mLastDraws;
  for (const BrickDraw& d : bricks) {
    const store::Vec3i& grid = meta.levels[d.key.level].bricks;
    Drawn& drawn = mDrawn[d.key.level][size_t((int64_t(d.key.k) * grid.y + d.key.j) * grid.x + d.key.i)];
    same = same && drawn.frame == last && drawn.standIn == d.standIn;
    drawn = {mFrame, d.standIn};
  }
  mLastDraws = bricks.size();
  mUnchanged = same;
  mEnded = false;
  if (mUnchanged || !prefetch) return;
  // Decoding runs ahead on the cache's workers, in the order the bricks will be drawn, a window at a time: the
  // cache's queue drops its oldest requests when full, and those would be the ones needed first.
  for (const BrickDraw& d : bricks)
    if (!mAtlas.slots().resident(d.source())) mToPage.push_back(d.source());
  prefetchUpTo(kPrefetchWindow);
}

void Residency::endFrame() {
  mEndGeneration = mAtlas.slots().generation();
  // A frame of no more bricks than slots was one batch: every brick it drew is still in the atlas. A frame of
  // several batches evicted its first bricks for its last.
  mEnded = mLastDraws <= size_t(mAtlas.capacity());
}

void Residency::prefetchUpTo(size_t end) {
  end = std::min(end, mToPage.size());
  if (end > mPrefetched)
    mCache->prefetch(std::span<const store::BrickKey>(mToPage).subspan(mPrefetched, end - mPrefetched));
  mPrefetched = std::max(mPrefetched, end);
}

std::optional<Residency::Resident> Residency::acquire(const store::BrickKey& key, int subBlock, FrameStats& stats) {
  const auto acquired = mAtlas.slots().acquire(key);
  if (!acquired) return std::nullopt;
  const store::BrickStore& s = *mCache->store();
  const int B = s.brickSize();
  const store::Vec3i& dims = s.level(int(key.level)).dims;
  const store::Vec3i lo{int64_t(key.i) * B, int64_t(key.j) * B, int64_t(key.k) * B};
  const store::Vec3i owned{std::min<int64_t>(lo.x + B, dims.x) - lo.x, std::min<int64_t>(lo.y + B, dims.y) - lo.y,
                           std::min<int64_t>(lo.z + B, dims.z) - lo.z};
  SubBlockRanges& ranges = mSlotRanges[size_t(acquired->slot.index)];
  if (!acquired->resident) {
    prefetchUpTo(++mPaged + kPrefetchWindow);
    store::BrickHandle brick;
    try {
      brick = mCache->get(key);
      mAtlas.upload(acquired->slot, *brick);
    } catch (...) {
      mAtlas.slots().forget(key);  // the slot holds no brick now: a later frame must read it again, not draw it
      throw;
    }
    ranges = subBlock ? SubBlockRanges(*brick, B, subBlock, owned) : SubBlockRanges();
    stats.bricksPagedIn += 1;
    stats.bricksEvicted += acquired->evicted ? 1 : 0;
  } else if (subBlock && ranges.subBlock() != subBlock) {
    ranges = SubBlockRanges(*mCache->get(key), B, subBlock, owned);
  }
  return Resident{acquired->slot, mAtlas.slotOrigin(acquired->slot), mAtlas.orientation(key), &ranges};
}

}  // namespace voxbrick::render
