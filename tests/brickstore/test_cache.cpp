// Tests of BrickCache: exact bytes, hit/miss and decode accounting, segmented LRU eviction, the byte budget under
// concurrency, prefetch, shared in-flight decodes and corrupt bricks.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <fstream>
#include <latch>
#include <ostream>
#include <random>
#include <thread>
#include <unordered_map>
#include <vector>

#include "brickstore/format/Errors.h"
#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"
#include "brickstore/source/VolumeSource.h"
#include "support/TestSupport.h"

namespace voxbrick::store {

// Readable keys in gtest failure messages (found by argument-dependent lookup, so not in the unnamed namespace).
[[maybe_unused]] static void PrintTo(const BrickKey& key, std::ostream* os) { *os << toString(key); }

namespace {

using namespace std::chrono_literals;

/// A deterministic u16 volume of 100x70x50 whose corner x < 48, z < 30 is zero (the background), so that the
/// bricks there are empty; the rest is a gradient plus hashed noise, never zero.
class NoiseSource : public VolumeSource {
 public:
  NoiseSource() {
    mInfo.dims = {100, 70, 50};
    mInfo.type = ValueType::U16;
    mInfo.background = 0;
    mInfo.description = "test noise u16 100x70x50";
  }
  const VolumeInfo& info() const override { return mInfo; }
  void readSlices(int64_t count, void* dst) override {
    if (count < 0 || mNextZ + count > mInfo.dims.z) throw InputError("NoiseSource: read past the last slice");
    auto* out = static_cast<uint16_t*>(dst);
    for (int64_t z = mNextZ; z < mNextZ + count; ++z)
      for (int64_t y = 0; y < mInfo.dims.y; ++y)
        for (int64_t x = 0; x < mInfo.dims.x; ++x) *out++ = value(x, y, z);
    mNextZ += count;
  }
  static uint16_t value(int64_t x, int64_t y, int64_t z) {
    if (x < 48 && z < 30) return 0;
    uint64_t h = static_cast<uint64_t>(x * 73856093 ^ y * 19349663 ^ z * 83492791) * 0x9E3779B97F4A7C15ull;
    return static_cast<uint16_t>(1 + (x * 7 + y * 3 + z) % 512 + ((h >> 40) & 63));
  }

 private:
  VolumeInfo mInfo;
  int64_t mNextZ = 0;
};

/// The prepared test store, built once per process, with every brick's reference bytes.
struct TestStore {
  test::ScratchDir dir;
  std::shared_ptr<const BrickStore> store;
  std::vector<BrickKey> allKeys, storedKeys, emptyKeys;
  std::unordered_map<BrickKey, std::vector<char>> reference;

  TestStore() {
    NoiseSource source;
    PrepOptions options;
    options.brickSize = 16;
    options.writeVdb = false;
    options.threads = 2;
    prepStore(source, dir / "store", options);
    store = BrickStore::open(dir / "store");
    for (int l = 0; l < store->levelCount(); ++l) {
      const Vec3i bricks = store->level(l).bricks;
      for (int64_t k = 0; k < bricks.z; ++k)
        for (int64_t j = 0; j < bricks.y; ++j)
          for (int64_t i = 0; i < bricks.x; ++i) {
            BrickKey key{static_cast<uint32_t>(l), static_cast<uint32_t>(i), static_cast<uint32_t>(j),
                         static_cast<uint32_t>(k)};
            allKeys.push_back(key);
            (store->isStored(key) ? storedKeys : emptyKeys).push_back(key);
            std::vector<char> bytes(store->brickBytes());
            store->readBrick(key, bytes.data());
            reference.emplace(key, std::move(bytes));
          }
    }
  }
};

const TestStore& testStore() {
  static const TestStore instance;
  return instance;
}

bool sameBytes(const Brick& brick, const std::vector<char>& expected) {
  return brick.bytes() == expected.size() && std::memcmp(brick.data(), expected.data(), expected.size()) == 0;
}

/// Polls the cache's stats until `done` holds or `limit` passes; returns whether it held.
template <typename Pred>
bool waitFor(const BrickCache& cache, Pred done, std::chrono::milliseconds limit = 5000ms) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (done(cache.stats())) return true;
    std::this_thread::sleep_for(2ms);
  }
  return done(cache.stats());
}

bool prefetchIdle(const CacheStats& s) { return s.prefetchQueued == 0 && s.inFlight == 0; }

class BrickCacheTest : public ::testing::Test {
 protected:
  const TestStore& ts = testStore();
  const size_t bb = ts.store->brickBytes();
};

TEST_F(BrickCacheTest, StoreHasStoredAndEmptyBricks) {
  ASSERT_GE(ts.storedKeys.size(), 40u);
  ASSERT_GE(ts.emptyKeys.size(), 4u);
  EXPECT_EQ(bb, 18u * 18u * 18u * 2u);
}

TEST_F(BrickCacheTest, GetMatchesReadBrickForEveryBrick) {
  BrickCache cache(ts.store, 1u << 30, 0);
  for (int pass = 0; pass < 2; ++pass)
    for (const BrickKey& key : ts.allKeys) {
      BrickHandle brick = cache.get(key);
      ASSERT_TRUE(brick);
      EXPECT_EQ(brick->key(), key);
      EXPECT_EQ(brick->type(), ValueType::U16);
      EXPECT_EQ(brick->isEmpty(), !ts.store->isStored(key)) << toString(key);
      EXPECT_TRUE(sameBytes(*brick, ts.reference.at(key))) << toString(key) << " pass " << pass;
    }
  const CacheStats s = cache.stats();
  EXPECT_EQ(s.bricksDecoded, ts.storedKeys.size());
  EXPECT_EQ(s.misses, ts.storedKeys.size());
  EXPECT_EQ(s.hits, ts.storedKeys.size());
}

TEST_F(BrickCacheTest, CountsHitsAndMisses) {
  BrickCache cache(ts.store, 10 * bb, 0);
  const BrickKey a = ts.storedKeys[0], b = ts.storedKeys[1];
  BrickHandle first = cache.get(a);
  EXPECT_EQ(cache.get(a), first);  // a hit returns the very same brick
  cache.get(b);
  cache.get(a);
  const CacheStats s = cache.stats();
  EXPECT_EQ(s.misses, 2u);
  EXPECT_EQ(s.hits, 2u);
  EXPECT_EQ(s.bricksDecoded, 2u);
  EXPECT_EQ(s.bytesDecoded, 2 * bb);
  EXPECT_EQ(s.residentBricks, 2u);
  EXPECT_EQ(s.residentBytes, 2 * bb);
  EXPECT_EQ(s.budgetBytes, 10 * bb);
  EXPECT_EQ(s.evictions, 0u);
}

TEST_F(BrickCacheTest, EmptyBricksCostNoDecode) {
  BrickCache cache(ts.store, 10 * bb, 0);
  const void* shared = nullptr;
  for (int pass = 0; pass < 3; ++pass)
    for (const BrickKey& key : ts.emptyKeys) {
      BrickHandle brick = cache.get(key);
      EXPECT_TRUE(brick->isEmpty());
      EXPECT_EQ(brick->key(), key);
      EXPECT_TRUE(sameBytes(*brick, ts.reference.at(key)));
      if (!shared) shared = brick->data();
      EXPECT_EQ(brick->data(), shared);  // one background buffer for all of them
    }
  const CacheStats s = cache.stats();
  EXPECT_EQ(s.bricksDecoded, 0u);
  EXPECT_EQ(s.bytesDecoded, 0u);
  EXPECT_EQ(s.emptyGets, 3 * ts.emptyKeys.size());
  EXPECT_EQ(s.hits + s.misses, 0u);
  EXPECT_EQ(s.residentBytes, 0u);
  EXPECT_EQ(s.liveBytes, 0u);
}

TEST_F(BrickCacheTest, EvictsLeastRecentlyUsedProbationFirst) {
  BrickCache cache(ts.store, 3 * bb, 0);
  const auto& k = ts.storedKeys;
  cache.get(k[0]);
  cache.get(k[1]);
  cache.get(k[2]);
  cache.get(k[3]);  // evicts k[0], the least recently used
  EXPECT_EQ(cache.residentKeys(), (std::vector<BrickKey>{k[3], k[2], k[1]}));
  cache.get(k[1]);  // a second use: k[1] moves to the protected segment
  cache.get(k[4]);  // evicts k[2], the least recently used of probation, although k[1] is older
  EXPECT_EQ(cache.residentKeys(), (std::vector<BrickKey>{k[1], k[4], k[3]}));
  cache.get(k[5]);  // evicts k[3]
  EXPECT_EQ(cache.residentKeys(), (std::vector<BrickKey>{k[1], k[5], k[4]}));
  const CacheStats s = cache.stats();
  EXPECT_EQ(s.evictions, 3u);
  EXPECT_EQ(s.hits, 1u);
  EXPECT_EQ(s.misses, 6u);
  EXPECT_EQ(s.residentBytes, 3 * bb);
  EXPECT_EQ(s.peakResidentBytes, 3 * bb);
  cache.get(k[0]);  // was evicted: decoded again
  EXPECT_EQ(cache.stats().bricksDecoded, 7u);
}

TEST_F(BrickCacheTest, AShrunkBudgetEvictsDownToItAtOnce) {
  BrickCache cache(ts.store, 6 * bb, 0);
  const auto& k = ts.storedKeys;
  for (int i = 0; i < 6; ++i) cache.get(k[size_t(i)]);
  cache.get(k[0]);  // protected: the hot one
  ASSERT_EQ(cache.stats().residentBytes, 6 * bb);
  cache.setBudget(2 * bb);
  EXPECT_EQ(cache.budgetBytes(), 2 * bb);
  const CacheStats s = cache.stats();
  EXPECT_EQ(s.budgetBytes, 2 * bb);
  EXPECT_EQ(s.residentBytes, 2 * bb);
  EXPECT_EQ(s.evictions, 4u);
  EXPECT_EQ(cache.residentKeys().front(), k[0]) << "the brick used twice stays";
  // Growing it back lets bricks in again.
  cache.setBudget(6 * bb);
  for (int i = 1; i < 6; ++i) cache.get(k[size_t(i)]);
  EXPECT_EQ(cache.stats().residentBytes, 6 * bb);
}

TEST_F(BrickCacheTest, HotSetSurvivesPrefetchBurst) {
  BrickCache cache(ts.store, 8 * bb, 2);
  const auto& k = ts.storedKeys;
  for (int use = 0; use < 2; ++use)
    for (int h = 0; h < 3; ++h) cache.get(k[h]);
  std::vector<BrickKey> burst(k.begin() + 3, k.begin() + 40);
  cache.prefetch(burst);
  ASSERT_TRUE(waitFor(cache, prefetchIdle));
  const uint64_t decoded = cache.stats().bricksDecoded;
  for (int h = 0; h < 3; ++h) cache.get(k[h]);
  EXPECT_EQ(cache.stats().bricksDecoded, decoded) << "the burst evicted a brick of the hot set";
  EXPECT_GT(cache.stats().evictions, 0u);
}

TEST_F(BrickCacheTest, BudgetSmallerThanOneBrick) {
  for (size_t budget : {size_t{0}, bb - 1}) {
    BrickCache cache(ts.store, budget, 1);
    const BrickKey key = ts.storedKeys[5];
    BrickHandle brick = cache.get(key);
    EXPECT_TRUE(sameBytes(*brick, ts.reference.at(key)));
    EXPECT_TRUE(sameBytes(*cache.get(key), ts.reference.at(key)));
    cache.prefetch(std::span<const BrickKey>(ts.storedKeys));  // nothing could be kept: ignored
    const CacheStats s = cache.stats();
    EXPECT_EQ(s.misses, 2u);
    EXPECT_EQ(s.hits, 0u);
    EXPECT_EQ(s.bricksDecoded, 2u);
    EXPECT_EQ(s.residentBytes, 0u);
    EXPECT_EQ(s.peakResidentBytes, 0u);
    EXPECT_EQ(s.prefetchQueued, 0u);
    EXPECT_EQ(s.liveBytes, bb);  // `brick` is still held
  }
}

TEST_F(BrickCacheTest, HandlesOutliveEvictionAndTheCache) {
  BrickHandle kept;
  {
    BrickCache cache(ts.store, bb, 0);
    kept = cache.get(ts.storedKeys[0]);
    cache.get(ts.storedKeys[1]);  // evicts the first
    CacheStats s = cache.stats();
    EXPECT_EQ(s.evictions, 1u);
    EXPECT_EQ(s.residentBytes, bb);
    EXPECT_EQ(s.liveBytes, 2 * bb);
    EXPECT_EQ(s.peakLiveBytes, 2 * bb);
    EXPECT_TRUE(sameBytes(*kept, ts.reference.at(ts.storedKeys[0])));
  }
  EXPECT_TRUE(sameBytes(*kept, ts.reference.at(ts.storedKeys[0])));
}

TEST_F(BrickCacheTest, RejectsBadArgumentsAndKeys) {
  EXPECT_THROW(BrickCache(nullptr, bb), InputError);
  EXPECT_THROW(BrickCache(ts.store, bb, -1), InputError);
  BrickCache cache(ts.store, bb, 0);
  EXPECT_THROW(cache.get(BrickKey{0, 1000, 0, 0}), InputError);
  EXPECT_THROW(cache.get(BrickKey{999, 0, 0, 0}), InputError);
}

class BrickCachePrefetch : public BrickCacheTest {};

TEST_F(BrickCachePrefetch, MakesLaterGetsHits) {
  BrickCache cache(ts.store, 1u << 30, 2);
  std::vector<BrickKey> keys = ts.allKeys;  // empty keys are skipped
  keys.push_back(BrickKey{0, 5000, 0, 0});  // keys outside the store are ignored
  cache.prefetch(keys);
  cache.prefetch(keys);  // resident, in-flight and queued keys are skipped
  ASSERT_TRUE(waitFor(cache, [&](const CacheStats& s) { return s.bricksDecoded == ts.storedKeys.size(); }));
  ASSERT_TRUE(waitFor(cache, prefetchIdle));
  for (const BrickKey& key : ts.storedKeys) EXPECT_TRUE(sameBytes(*cache.get(key), ts.reference.at(key)));
  for (const BrickKey& key : ts.storedKeys) cache.get(key);
  const CacheStats s = cache.stats();
  EXPECT_EQ(s.bricksDecoded, ts.storedKeys.size());
  EXPECT_EQ(s.misses, 0u);
  EXPECT_EQ(s.hits, 2 * ts.storedKeys.size());
  EXPECT_EQ(s.prefetchHits, ts.storedKeys.size());  // only the first use of each prefetched brick
  EXPECT_EQ(s.prefetchRequests, 2 * keys.size());
  EXPECT_EQ(s.prefetchDrops, 0u);
}

TEST_F(BrickCachePrefetch, QueueDropsOldestAndCancels) {
  BrickCache cache(ts.store, 1u << 30, 1, 4);
  const std::vector<BrickKey> keys(ts.storedKeys.begin(), ts.storedKeys.begin() + 30);
  cache.prefetch(keys);  // the worker cannot take from the queue while prefetch() fills it
  EXPECT_EQ(cache.stats().prefetchDrops, 26u);
  cache.cancelPrefetch();
  EXPECT_EQ(cache.stats().prefetchQueued, 0u);
  ASSERT_TRUE(waitFor(cache, prefetchIdle));
  const CacheStats s = cache.stats();
  EXPECT_EQ(s.prefetchDrops + s.bricksDecoded, 30u);
  for (const BrickKey& key : cache.residentKeys())  // only the newest requests survived the bound
    EXPECT_NE(std::find(keys.end() - 4, keys.end(), key), keys.end()) << toString(key);
}

TEST_F(BrickCachePrefetch, WithoutWorkersDoesNothing) {
  BrickCache cache(ts.store, 1u << 30, 0);
  cache.prefetch(std::span<const BrickKey>(ts.storedKeys));
  const CacheStats s = cache.stats();
  EXPECT_EQ(s.prefetchRequests, ts.storedKeys.size());
  EXPECT_EQ(s.prefetchDrops, ts.storedKeys.size());
  EXPECT_EQ(s.bricksDecoded, 0u);
  EXPECT_EQ(s.prefetchQueued, 0u);
}

TEST_F(BrickCachePrefetch, DestructorJoinsWithFullQueue) {
  const auto start = std::chrono::steady_clock::now();
  for (int round = 0; round < 5; ++round) {
    BrickCache cache(ts.store, 4 * bb, 2);
    cache.prefetch(std::span<const BrickKey>(ts.storedKeys));
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, 3s);
}

class BrickCacheConcurrency : public BrickCacheTest {};

TEST_F(BrickCacheConcurrency, SameKeyDecodesOnce) {
  constexpr int kThreads = 8;
  BrickCache cache(ts.store, 1u << 30, 0);
  const size_t rounds = std::min<size_t>(20, ts.storedKeys.size());
  for (size_t r = 0; r < rounds; ++r) {
    const BrickKey key = ts.storedKeys[r];
    std::latch start(kThreads);
    std::vector<BrickHandle> got(kThreads);
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t)
      threads.emplace_back([&, t] {
        start.arrive_and_wait();
        got[static_cast<size_t>(t)] = cache.get(key);
      });
    for (auto& thread : threads) thread.join();
    for (const BrickHandle& brick : got) EXPECT_EQ(brick, got[0]);
    EXPECT_TRUE(sameBytes(*got[0], ts.reference.at(key)));
    EXPECT_EQ(cache.stats().bricksDecoded, r + 1);
  }
  const CacheStats s = cache.stats();
  EXPECT_EQ(s.hits + s.misses, rounds * kThreads);
}

TEST_F(BrickCacheConcurrency, BudgetHoldsUnderReadersAndPrefetch) {
  constexpr int kReaders = 8;
  const size_t budget = 12 * bb + bb / 2;
  BrickCache cache(ts.store, budget, 2, 64);
  std::atomic<bool> stop{false};
  std::atomic<int> badBricks{0};
  std::atomic<size_t> monitorMax{0}, monitorSamples{0};

  std::thread monitor([&] {
    // Two views independent of the stats counters' arithmetic: the counter itself and the count of resident keys.
    while (!stop.load()) {
      const size_t bytes = cache.stats().residentBytes;
      const size_t keyed = cache.residentKeys().size() * bb;
      const size_t seen = std::max(bytes, keyed);
      if (seen > monitorMax.load()) monitorMax.store(seen);
      monitorSamples.fetch_add(1);
    }
  });
  std::vector<std::thread> readers;
  for (int t = 0; t < kReaders; ++t)
    readers.emplace_back([&, t] {
      std::mt19937 rng(1234u + static_cast<unsigned>(t));
      const auto& all = ts.allKeys;
      std::uniform_int_distribution<size_t> anyKey(0, all.size() - 1), hotKey(0, 9);
      std::vector<BrickKey> ahead;
      for (int n = 0; !stop.load(); ++n) {
        const BrickKey key = (n % 2 == 0) ? ts.storedKeys[hotKey(rng)] : all[anyKey(rng)];
        BrickHandle brick = cache.get(key);
        if (brick->key() != key || !sameBytes(*brick, ts.reference.at(key))) badBricks.fetch_add(1);
        if (n % 8 == 0) {
          ahead.clear();
          for (int p = 0; p < 16; ++p) ahead.push_back(all[anyKey(rng)]);
          cache.prefetch(ahead);
        }
        if (n % 500 == 499) cache.cancelPrefetch();
      }
    });
  std::this_thread::sleep_for(1s);
  stop.store(true);
  for (auto& reader : readers) reader.join();
  monitor.join();

  const CacheStats s = cache.stats();
  EXPECT_EQ(badBricks.load(), 0);
  EXPECT_GT(monitorSamples.load(), 10u);
  EXPECT_LE(monitorMax.load(), budget);
  EXPECT_LE(s.peakResidentBytes, budget);
  EXPECT_LE(s.residentBytes, budget);
  EXPECT_GE(s.peakResidentBytes, 12 * bb);  // the test did fill the cache
  EXPECT_GT(s.evictions, 0u);
  EXPECT_GT(s.prefetchRequests, 0u);
  EXPECT_GE(s.peakLiveBytes, s.peakResidentBytes);
  EXPECT_EQ(s.decodeErrors, 0u);
}

class BrickCacheCorrupt : public BrickCacheTest {};

TEST_F(BrickCacheCorrupt, ErrorReachesEveryCallerAndCacheStaysUsable) {
  test::ScratchDir scratch;
  std::filesystem::copy(ts.dir / "store", scratch / "store", std::filesystem::copy_options::recursive);
  const auto bricksPath = scratch / "store" / "bricks.bin";
  const uint64_t middle = std::filesystem::file_size(bricksPath) / 2;

  // The brick whose frame holds the middle of bricks.bin; flip a few bytes in the middle of its frame only.
  BrickKey bad{};
  uint64_t flipAt = 0;
  for (const BrickKey& key : ts.storedKeys) {
    const BrickRecord& r = ts.store->record(key);
    if (r.offset <= middle && middle < r.offset + r.compressedSize) {
      bad = key;
      flipAt = r.offset + r.compressedSize / 2;
      ASSERT_GE(r.compressedSize, 64u);
    }
  }
  ASSERT_GT(flipAt, 0u);
  {
    std::fstream file(bricksPath, std::ios::in | std::ios::out | std::ios::binary);
    std::vector<char> bytes(8);
    file.seekg(static_cast<std::streamoff>(flipAt));
    file.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    for (char& c : bytes) c = static_cast<char>(~c);
    file.seekp(static_cast<std::streamoff>(flipAt));
    file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    ASSERT_TRUE(file.good());
  }
  auto store = BrickStore::open(scratch / "store");
  BrickCache cache(store, 1u << 30, 2);

  constexpr int kThreads = 8;
  std::atomic<int> corrupt{0}, other{0};
  std::latch start(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&] {
      start.arrive_and_wait();
      try {
        cache.get(bad);
      } catch (const CorruptStoreError&) {
        corrupt.fetch_add(1);
      } catch (...) {
        other.fetch_add(1);
      }
    });
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(corrupt.load(), kThreads);
  EXPECT_EQ(other.load(), 0);

  // Not poisoned: a later get decodes again (and fails again), a prefetch of it fails quietly, others work.
  const uint64_t errors = cache.stats().decodeErrors;
  EXPECT_GE(errors, 1u);
  EXPECT_THROW(cache.get(bad), CorruptStoreError);
  EXPECT_EQ(cache.stats().decodeErrors, errors + 1);
  const BrickKey badKeys[] = {bad};
  cache.prefetch(badKeys);
  ASSERT_TRUE(waitFor(cache, [&](const CacheStats& s) { return s.decodeErrors == errors + 2 && prefetchIdle(s); }));
  for (const BrickKey& key : ts.storedKeys) {
    if (key == bad) continue;
    EXPECT_TRUE(sameBytes(*cache.get(key), ts.reference.at(key))) << toString(key);
  }
  EXPECT_EQ(cache.stats().residentBricks, ts.storedKeys.size() - 1);
}

}  // namespace
}  // namespace voxbrick::store
