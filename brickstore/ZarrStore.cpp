// An OME-Zarr read live: the pass over the present chunks at open, bricks cut from chunks, coarse bricks either the
// Zarr's own level or averaged from finer bricks.
#include "brickstore/ZarrStore.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <limits>
#include <type_traits>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "brickstore/BrickCache.h"
#include "brickstore/Convert.h"
#include "brickstore/Errors.h"
#include "brickstore/HistogramBuilder.h"
#include "brickstore/InputErrors.h"
#include "brickstore/LevelSources.h"
#include "brickstore/LiveBricks.h"
#include "brickstore/SlabBricker.h"

namespace voxbrick::store {
namespace {

using live::averageFromFiner;
using live::brickVoxels;
using live::gatherSamples;

using Clock = std::chrono::steady_clock;

/// The statistics of the voxels a level-0 brick owns (no border), so that every voxel is counted once.
struct OwnedStats {
  double min = std::numeric_limits<double>::max(), max = std::numeric_limits<double>::lowest();
  int64_t active = 0;
};

}  // namespace

std::vector<bool> zarrOwnLevels(const ZarrMeta& meta, int brickSize) {
  const std::vector<Vec3i> pyramid = pyramidDims(meta.levels.front().dims, brickSize);
  std::vector<bool> own(pyramid.size(), false);
  own[0] = true;
  for (size_t m = 1; m < pyramid.size(); ++m)
    own[m] = own[m - 1] && m < meta.levels.size() && meta.levels[m].dims == pyramid[m];
  return own;
}

ZarrStore::~ZarrStore() = default;

std::shared_ptr<const ZarrStore> ZarrStore::open(const std::filesystem::path& dir, const StoreOpenOptions& options,
                                                 size_t chunkCacheBytes) {
  checkBrickSize(options.brickSize);
  if (!options.gridName.empty()) throw InputError(dir.string() + ": --grid applies to a .vdb file only");
  std::shared_ptr<ZarrStore> store(new ZarrStore());
  const auto start = Clock::now();
  ZarrMeta zarrMeta = readZarrMeta(dir, {options.time, options.channel});
  // The records are sized from the bricks: refused here, before the chunk files are looked for or anything sized.
  const Vec3i d = zarrMeta.levels.front().dims;
  const int64_t B = options.brickSize;
  const double level0Bricks = double(divUp(d.x, B)) * double(divUp(d.y, B)) * double(divUp(d.z, B));
  if (level0Bricks > double(kMaxBricks))
    throw InputError((dir / zarrMeta.levels.front().path / ".zarray").string() + ": field 'shape' " + dimsText(d) +
                     " in bricks of " + std::to_string(B) + " makes " + std::to_string(int64_t(level0Bricks)) +
                     " bricks, more than 2^26 (use a larger --brick, or prep it)");
  store->mChunks = std::make_unique<ZarrChunks>(std::move(zarrMeta), chunkCacheBytes);
  const ZarrMeta& zm = store->mChunks->meta();
  const ZarrArrayMeta& l0 = zm.levels.front();
  store->mPath = dir;
  store->mOwn = zarrOwnLevels(zm, options.brickSize);

  StoreMeta& meta = store->mMeta;
  meta.dims = l0.dims;
  meta.spacing = l0.scale;
  meta.orientation.origin = l0.translation;
  meta.type = store->mChunks->type();
  meta.background = store->mChunks->background();
  meta.brickSize = options.brickSize;
  meta.bytesRaw = meta.dims.volume() * int64_t(valueSize(meta.type));
  int own = 0;
  for (bool o : store->mOwn) own += o;
  meta.source = zm.description() + "; store levels 0-" + std::to_string(own - 1) + " are its own" +
                (own < int(store->mOwn.size())
                     ? ", the coarser averaged from the level below (the Zarr has no level of their dims)"
                     : "");
  store->layOutLevels();
  namingInput({dir.string()}, [&] {
    for (int m = 0; m < store->levelCount(); ++m) {
      if (store->mOwn[size_t(m)])
        store->scanOwnLevel(m);
      else
        store->deriveCoarseRecords(m);
    }
    store->buildOctree();
    store->level0Statistics();
  });
  store->mOpenStats.scanSeconds = std::chrono::duration<double>(Clock::now() - start).count();
  store->mOpenStats.chunksPresent = store->mChunks->chunksPresent(0);
  store->mOpenStats.chunksTotal = l0.chunkGrid.volume();
  store->mOpenStats.chunksDecoded = store->mChunks->chunksDecoded();
  store->mOpenStats.ownLevels = own;
  return store;
}

void ZarrStore::scanOwnLevel(int level) {
  const int64_t B = mMeta.brickSize, E = B + 2;
  const Vec3i n = mMeta.levels[size_t(level)].dims, nb = mMeta.levels[size_t(level)].bricks;
  const uint32_t storedSize = uint32_t(brickBytes());
  const double bg = mMeta.background;
  // Level 0 of an integer type: the owned voxels' values are counted here, so that the statistics need no second
  // pass (values offset by 32768 for i16).
  const bool count = level == 0 && mMeta.type != ValueType::F32;
  tbb::enumerable_thread_specific<std::vector<uint64_t>> counts(
      [&] { return std::vector<uint64_t>(count ? 65536 : 0); });
  std::atomic<int64_t> scanned{0};
  dispatchType(mMeta.type, [&](auto zero) {
    using T = decltype(zero);
    const int64_t offset = std::is_same_v<T, int16_t> ? 32768 : 0;
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, nb.volume()), [&](const tbb::blocked_range<int64_t>& r) {
      std::vector<T> block, samples(size_t(E * E * E));
      for (int64_t b = r.begin(); b != r.end(); ++b) {
        const Vec3i idx{b % nb.x, (b / nb.x) % nb.y, b / (nb.x * nb.y)};
        BrickRecord& rec = mRecords[recordIndex({uint32_t(level), uint32_t(idx.x), uint32_t(idx.y), uint32_t(idx.z)})];
        Vec3i lo, hi;
        brickVoxels(idx, B, n, lo, hi);
        if (!mChunks->anyChunk(level, lo, hi)) {
          rec = BrickRecord{0, 0, 0, float(bg), float(bg), 0};
          continue;
        }
        block.resize(size_t((hi.x - lo.x + 1) * (hi.y - lo.y + 1) * (hi.z - lo.z + 1)));
        mChunks->readRegion(level, lo, hi, block.data());
        gatherSamples(block.data(), lo, hi, idx, B, n, samples.data());
        bool empty = true;
        const MinMaxPair range = sampleRange(samples.data(), samples.size(), T(bg), empty);
        rec = BrickRecord{0, empty ? 0 : storedSize, 0, range.min, range.max, 0};
        scanned.fetch_add(1, std::memory_order_relaxed);
        if (!count || empty) continue;
        std::vector<uint64_t>& c = counts.local();
        const Vec3i own{std::min(B, n.x - idx.x * B), std::min(B, n.y - idx.y * B), std::min(B, n.z - idx.z * B)};
        for (int64_t z = 1; z <= own.z; ++z)
          for (int64_t y = 1; y <= own.y; ++y)
            for (int64_t x = 1; x <= own.x; ++x) ++c[size_t(int64_t(samples[size_t(x + E * (y + E * z))]) + offset)];
      }
    });
  });
  if (count) {
    mLevel0Counts.assign(65536, 0);
    for (const std::vector<uint64_t>& c : counts)
      for (size_t v = 0; v < c.size(); ++v) mLevel0Counts[v] += c[v];
  }
  mOpenStats.bricksScanned += scanned.load();
  LevelMeta& lm = mMeta.levels[size_t(level)];
  for (int64_t b = 0; b < nb.volume(); ++b)
    lm.bricksStored += mRecords[mLevels[size_t(level)].firstRecord + size_t(b)].compressedSize != 0;
}

void ZarrStore::level0Statistics() {
  const int64_t B = mMeta.brickSize;
  const Vec3i n = mMeta.dims, nb = mMeta.levels[0].bricks;
  const double bg = mMeta.background;
  // f32: the owned voxels of stored bricks are read again (their chunks too); the others hold only the background.
  std::vector<int64_t> stored;
  int64_t emptyVoxels = 0;
  auto owned = [&](const Vec3i& idx, Vec3i& lo, Vec3i& hi) {
    for (int a = 0; a < 3; ++a) lo[a] = idx[a] * B, hi[a] = std::min(idx[a] * B + B, n[a]) - 1;
  };
  for (int64_t b = 0; b < nb.volume(); ++b) {
    const Vec3i idx{b % nb.x, (b / nb.x) % nb.y, b / (nb.x * nb.y)};
    if (mRecords[size_t(b)].compressedSize != 0) {
      stored.push_back(b);
    } else {
      Vec3i lo, hi;
      owned(idx, lo, hi);
      emptyVoxels += (hi.x - lo.x + 1) * (hi.y - lo.y + 1) * (hi.z - lo.z + 1);
    }
  }
  if (!mLevel0Counts.empty()) return statisticsFromCounts(emptyVoxels);
  dispatchType(mMeta.type, [&](auto zero) {
    using T = decltype(zero);
    std::vector<OwnedStats> stats(stored.size());
    auto forStored = [&](auto&& fn) {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, stored.size()), [&](const tbb::blocked_range<size_t>& r) {
        std::vector<T> block;
        for (size_t s = r.begin(); s != r.end(); ++s) {
          const int64_t b = stored[s];
          Vec3i lo, hi;
          owned({b % nb.x, (b / nb.x) % nb.y, b / (nb.x * nb.y)}, lo, hi);
          block.resize(size_t((hi.x - lo.x + 1) * (hi.y - lo.y + 1) * (hi.z - lo.z + 1)));
          mChunks->readRegion(0, lo, hi, block.data());
          fn(s, block);
        }
      });
    };
    forStored([&](size_t s, const std::vector<T>& block) {
      OwnedStats& o = stats[s];
      for (T v : block) {
        o.min = std::min(o.min, double(v));
        o.max = std::max(o.max, double(v));
        o.active += double(v) != bg;
      }
    });
    double lo = std::numeric_limits<double>::max(), hi = std::numeric_limits<double>::lowest();
    int64_t active = 0;
    for (const OwnedStats& o : stats) lo = std::min(lo, o.min), hi = std::max(hi, o.max), active += o.active;
    if (emptyVoxels > 0) lo = std::min(lo, bg), hi = std::max(hi, bg);
    mMeta.valueMin = lo;
    mMeta.valueMax = hi;
    mMeta.activeVoxels = active;
    const HistogramBuilder empty(mMeta.type, lo, hi);
    tbb::enumerable_thread_specific<HistogramBuilder> perThread([&] { return empty; });
    forStored([&](size_t, const std::vector<T>& block) { perThread.local().add(block.data(), int64_t(block.size())); });
    HistogramBuilder all(mMeta.type, lo, hi);
    for (const HistogramBuilder& h : perThread) all.merge(h);
    all.addRepeated(bg, uint64_t(emptyVoxels));
    mMeta.histogram = all.finish();
  });
}

void ZarrStore::statisticsFromCounts(int64_t emptyVoxels) {
  const double bg = mMeta.background;
  const int64_t offset = mMeta.type == ValueType::I16 ? 32768 : 0;
  std::vector<uint64_t> counts = std::move(mLevel0Counts);
  counts[size_t(int64_t(bg) + offset)] += uint64_t(emptyVoxels);
  double lo = std::numeric_limits<double>::max(), hi = std::numeric_limits<double>::lowest();
  int64_t active = 0;
  for (size_t v = 0; v < counts.size(); ++v) {
    if (!counts[v]) continue;
    const double value = double(int64_t(v) - offset);
    lo = std::min(lo, value), hi = std::max(hi, value);
    if (value != bg) active += int64_t(counts[v]);
  }
  mMeta.valueMin = lo;
  mMeta.valueMax = hi;
  mMeta.activeVoxels = active;
  HistogramBuilder histogram(mMeta.type, lo, hi);
  for (size_t v = 0; v < counts.size(); ++v)
    if (counts[v]) histogram.addRepeated(double(int64_t(v) - offset), counts[v]);
  mMeta.histogram = histogram.finish();
}

void ZarrStore::readStored(const BrickKey& key, void* dst, const BrickSamplesFetch& finer) const {
  const int64_t B = mMeta.brickSize;
  const int level = int(key.level);
  const Vec3i idx{key.i, key.j, key.k};
  const Vec3i n = mMeta.levels[size_t(level)].dims;
  Vec3i lo, hi;
  brickVoxels(idx, B, n, lo, hi);
  if (!mOwn[size_t(level)] && !finer) {
    BrickCache cache(shared_from_this(), kFallbackCacheBytes, 0);
    readStored(key, dst, [&cache](const BrickKey& k) {
      BrickHandle brick = cache.get(k);
      return std::shared_ptr<const void>(brick, brick->data());
    });
    return;
  }
  namingInput({mPath.string()}, [&] {
    dispatchType(mMeta.type, [&](auto zero) {
      using T = decltype(zero);
      std::vector<T> block(size_t((hi.x - lo.x + 1) * (hi.y - lo.y + 1) * (hi.z - lo.z + 1)));
      if (mOwn[size_t(level)])
        mChunks->readRegion(level, lo, hi, block.data());
      else
        averageFromFiner(*this, key.level - 1, lo, hi, mMeta.levels[size_t(level) - 1].dims, finer, block.data());
      gatherSamples(block.data(), lo, hi, idx, B, n, static_cast<T*>(dst));
    });
  });
}

}  // namespace voxbrick::store
