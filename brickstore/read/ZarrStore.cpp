// An OME-Zarr read live: the pass over the present chunks at open, bricks cut from chunks, coarse bricks either the
// Zarr's own level or averaged from finer bricks.
#include "brickstore/read/ZarrStore.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <limits>
#include <type_traits>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "brickstore/format/BrickMath.h"
#include "brickstore/format/Convert.h"
#include "brickstore/format/Errors.h"
#include "brickstore/format/HistogramBuilder.h"
#include "brickstore/format/InputErrors.h"
#include "brickstore/read/LiveBricks.h"

namespace voxbrick::store {
namespace {

using live::averageFromFiner;
using live::gatherSamples;
using live::OwnedStats;

using Clock = std::chrono::steady_clock;

}  // namespace

/// What the scan of level 0 found of the voxels its non-empty bricks own.
struct ZarrStore::Level0Scan {
  OwnedStats stats;              ///< their range and voxels other than the background
  std::vector<uint64_t> counts;  ///< u8, u16, i16: their voxels by value (offset by 32768 for i16); f32: empty
};

ZarrStore::~ZarrStore() = default;

std::shared_ptr<const ZarrStore> ZarrStore::open(const std::filesystem::path& dir, const StoreOpenOptions& options,
                                                 size_t chunkCacheBytes) {
  checkBrickSize(options.brickSize);
  if (!options.gridName.empty()) throw InputError(dir.string() + ": --grid applies to a .vdb file only");
  std::shared_ptr<ZarrStore> store(new ZarrStore());
  const auto start = Clock::now();
  ZarrMeta zarrMeta = readZarrMeta(dir, {options.time, options.channel});
  // The records are sized from the bricks: refused here, before the chunk files are looked for or anything sized.
  checkLiveBrickCount(zarrMeta.levels.front().dims, options.brickSize,
                      (dir / zarrMeta.levels.front().path / ".zarray").string() + ": field 'shape'");
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
    Level0Scan level0;
    for (int m = 0; m < store->levelCount(); ++m) {
      if (!store->mOwn[size_t(m)])
        store->deriveCoarseRecords(m);
      else if (m == 0)
        level0 = store->scanOwnLevel(m);
      else
        store->scanOwnLevel(m);
    }
    store->buildOctree();
    store->level0Statistics(std::move(level0));
  });
  store->mOpenStats.scanSeconds = std::chrono::duration<double>(Clock::now() - start).count();
  store->mOpenStats.chunksPresent = store->mChunks->chunksPresent(0);
  store->mOpenStats.chunksTotal = l0.chunkGrid.volume();
  store->mOpenStats.chunksDecoded = store->mChunks->chunksDecoded();
  store->mOpenStats.ownLevels = own;
  return store;
}

ZarrStore::Level0Scan ZarrStore::scanOwnLevel(int level) {
  const int64_t B = mMeta.brickSize, E = B + 2;
  const Vec3i n = mMeta.levels[size_t(level)].dims, nb = mMeta.levels[size_t(level)].bricks;
  const uint32_t storedSize = uint32_t(brickBytes());
  const double bg = mMeta.background;
  // Level 0: the owned voxels' range and active count are taken here, and for an integer type their values counted
  // (offset by 32768 for i16), so that the statistics need no second pass (f32 needs one, for the histogram).
  const bool stats = level == 0, count = stats && mMeta.type != ValueType::F32;
  tbb::enumerable_thread_specific<std::vector<uint64_t>> counts(
      [&] { return std::vector<uint64_t>(count ? 65536 : 0); });
  tbb::enumerable_thread_specific<OwnedStats> owned;
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
        if (!stats || empty) continue;
        owned.local().merge(live::ownedStats(samples.data(), idx, B, n, bg));
        if (!count) continue;
        std::vector<uint64_t>& c = counts.local();
        const Vec3i own{std::min(B, n.x - idx.x * B), std::min(B, n.y - idx.y * B), std::min(B, n.z - idx.z * B)};
        for (int64_t z = 1; z <= own.z; ++z)
          for (int64_t y = 1; y <= own.y; ++y)
            for (int64_t x = 1; x <= own.x; ++x) ++c[size_t(int64_t(samples[size_t(x + E * (y + E * z))]) + offset)];
      }
    });
  });
  Level0Scan found;
  for (const OwnedStats& o : owned) found.stats.merge(o);
  if (count) {
    found.counts.assign(65536, 0);
    for (const std::vector<uint64_t>& c : counts)
      for (size_t v = 0; v < c.size(); ++v) found.counts[v] += c[v];
  }
  mOpenStats.bricksScanned += scanned.load();
  LevelMeta& lm = mMeta.levels[size_t(level)];
  for (int64_t b = 0; b < nb.volume(); ++b)
    lm.bricksStored += mRecords[mLevels[size_t(level)].firstRecord + size_t(b)].compressedSize != 0;
  return found;
}

void ZarrStore::level0Statistics(Level0Scan level0) {
  const int64_t B = mMeta.brickSize;
  const Vec3i n = mMeta.dims, nb = mMeta.levels[0].bricks;
  const double bg = mMeta.background;
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
  if (!level0.counts.empty()) return statisticsFromCounts(std::move(level0.counts), emptyVoxels);
  // f32: the range and active voxels came from the scan; the histogram, binned over that range, needs the owned
  // voxels of the stored bricks read again (their chunks too). The other bricks hold only the background.
  OwnedStats& all = level0.stats;
  if (emptyVoxels > 0) all.min = std::min(all.min, bg), all.max = std::max(all.max, bg);
  const double lo = all.min, hi = all.max;
  mMeta.valueMin = lo;
  mMeta.valueMax = hi;
  mMeta.activeVoxels = all.active;
  dispatchType(mMeta.type, [&](auto zero) {
    using T = decltype(zero);
    const HistogramBuilder empty(mMeta.type, lo, hi);
    tbb::enumerable_thread_specific<HistogramBuilder> perThread([&] { return empty; });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, stored.size()), [&](const tbb::blocked_range<size_t>& r) {
      std::vector<T> block;
      for (size_t s = r.begin(); s != r.end(); ++s) {
        const int64_t b = stored[s];
        Vec3i blo, bhi;
        owned({b % nb.x, (b / nb.x) % nb.y, b / (nb.x * nb.y)}, blo, bhi);
        block.resize(size_t((bhi.x - blo.x + 1) * (bhi.y - blo.y + 1) * (bhi.z - blo.z + 1)));
        mChunks->readRegion(0, blo, bhi, block.data());
        perThread.local().add(block.data(), int64_t(block.size()));
      }
    });
    HistogramBuilder histogram(mMeta.type, lo, hi);
    for (const HistogramBuilder& h : perThread) histogram.merge(h);
    histogram.addRepeated(bg, uint64_t(emptyVoxels));
    mMeta.histogram = histogram.finish();
  });
}

void ZarrStore::statisticsFromCounts(std::vector<uint64_t> counts, int64_t emptyVoxels) {
  const double bg = mMeta.background;
  const int64_t offset = mMeta.type == ValueType::I16 ? 32768 : 0;
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
  if (!mOwn[size_t(level)] && !finer)
    return live::readWithoutFetch(shared_from_this(), [&](const BrickSamplesFetch& f) { readStored(key, dst, f); });
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
