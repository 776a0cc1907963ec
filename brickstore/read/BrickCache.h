// A bounded host cache of decoded bricks with asynchronous prefetch, shared by the renderer and the server.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <future>
#include <list>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "brickstore/format/Types.h"
#include "brickstore/read/BrickStore.h"

namespace voxbrick::store {

class BrickCache;

/// One decoded brick: (B+2)^3 samples of the store's type, laid out as BrickStore::readBrick writes them.
/// Immutable once a BrickCache hands it out; shared by every holder of its handle, and alive as long as any handle
/// is, whether or not the cache still holds it.
class Brick {
 public:
  ~Brick();
  Brick(const Brick&) = delete;
  Brick& operator=(const Brick&) = delete;

  /// The brick this is.
  const BrickKey& key() const { return mKey; }
  /// The samples: bytes() bytes of type().
  const void* data() const { return mData; }
  /// Bytes of the samples, BrickStore::brickBytes().
  size_t bytes() const { return mBytes; }
  /// The store's value type.
  ValueType type() const { return mType; }
  /// True for a brick the store does not hold: every sample is the background, and its data is a buffer shared
  /// by all empty bricks of the cache (no decode, no disk I/O).
  bool isEmpty() const { return mEmpty; }

 private:
  friend class BrickCache;
  struct LiveBytes;

  Brick() = default;

  BrickKey mKey;
  const void* mData = nullptr;
  size_t mBytes = 0;
  ValueType mType = ValueType::F32;
  bool mEmpty = false;
  std::unique_ptr<std::byte[]> mOwned;             // decoded samples (null for empty bricks)
  std::shared_ptr<const std::byte[]> mBackground;  // the shared background samples (empty bricks only)
  std::shared_ptr<LiveBytes> mLive;                // counts decoded bytes alive anywhere (decoded bricks only)
};

/// A shared, immutable decoded brick. Never null when returned by BrickCache::get.
using BrickHandle = std::shared_ptr<const Brick>;

/// Counters of a BrickCache since it was constructed (sizes and peaks in bytes).
struct CacheStats {
  uint64_t hits = 0;              ///< gets of stored bricks served from the cache
  uint64_t misses = 0;            ///< gets of stored bricks that decoded or waited for an in-flight decode
  uint64_t emptyGets = 0;         ///< gets of empty (not stored) bricks; neither hits nor misses, never decoded
  uint64_t bricksDecoded = 0;     ///< successful decodes, by gets and prefetch workers
  uint64_t bytesDecoded = 0;      ///< decoded bytes of those
  uint64_t decodeErrors = 0;      ///< decodes that threw (by gets and prefetch workers)
  uint64_t evictions = 0;         ///< bricks dropped from the cache to make room
  uint64_t prefetchRequests = 0;  ///< keys passed to prefetch(), skipped ones included
  uint64_t prefetchHits = 0;      ///< hits on a brick a prefetch loaded that no get had used yet
  uint64_t prefetchDrops = 0;     ///< queued requests discarded undecoded: queue bound, cancelPrefetch, no workers
  size_t prefetchQueued = 0;      ///< requests waiting in the queue now
  size_t inFlight = 0;            ///< decodes running now
  size_t residentBricks = 0;      ///< bricks the cache holds now
  size_t residentBytes = 0;       ///< bytes of those; never above budgetBytes
  size_t peakResidentBytes = 0;   ///< the most residentBytes has been
  size_t budgetBytes = 0;         ///< the budget the cache was built with
  size_t liveBytes = 0;           ///< decoded bytes alive anywhere: resident, held by handles, or being decoded
  size_t peakLiveBytes = 0;       ///< the most liveBytes has been
};

/// Keeps recently used decoded bricks of one store in host memory, within a byte budget, and decodes bricks ahead
/// of use on worker threads. Every method may be called from many threads at once; decoding runs outside the
/// cache's lock.
///
/// Budget: the bytes of the bricks the cache itself holds never exceed the budget at any instant; room is made by
/// evicting before a brick is inserted, and a brick larger than the whole budget is returned but not cached.
/// Handles already given out keep their bricks alive after eviction, and bricks being decoded are not yet held,
/// so the process's decoded bytes can exceed the budget; CacheStats::liveBytes / peakLiveBytes report those.
/// Empty bricks share one background buffer of brickBytes() per cache, allocated on first use and outside the
/// budget.
///
/// Eviction is segmented LRU. A newly decoded brick (by a get or a prefetch) enters the probation segment; a hit on
/// a probation brick moves it to the protected segment, except the first get of a prefetched brick, which counts
/// as its first use and only refreshes it in probation. The protected segment holds at most 80% of the budget
/// (its least recently used bricks are demoted to probation beyond that). Victims are the least recently used
/// probation bricks, then, only if probation is empty, the least recently used protected ones; so a burst of
/// prefetches or one-off gets cannot flush the bricks that are used repeatedly.
///
/// Prefetch: requests wait in a queue of at most prefetchQueueLimit keys; when it is full the oldest requests are
/// dropped (the newest describe the current view best). With zero worker threads prefetch() does nothing but
/// count its keys as requests and drops.
class BrickCache {
 public:
  static constexpr size_t kDefaultPrefetchQueueLimit = 4096;

  /// Builds a cache over `store` (not null) holding at most `budgetBytes` of decoded bricks, with `prefetchThreads`
  /// (>= 0) worker threads. Throws InputError for a null store or negative thread count or zero queue limit.
  BrickCache(std::shared_ptr<const BrickStore> store, size_t budgetBytes, int prefetchThreads = 2,
             size_t prefetchQueueLimit = kDefaultPrefetchQueueLimit);
  /// Clears the prefetch queue, lets running decodes finish and joins the workers. No other call may be running.
  ~BrickCache();
  BrickCache(const BrickCache&) = delete;
  BrickCache& operator=(const BrickCache&) = delete;

  /// The store the bricks come from.
  const std::shared_ptr<const BrickStore>& store() const { return mStore; }
  /// The byte budget.
  size_t budgetBytes() const;
  /// Changes the budget; a smaller one evicts (least recently used first) down to it before returning. Handles
  /// already given out keep their bricks alive.
  void setBudget(size_t budgetBytes);
  /// The most prefetch requests that wait at once.
  size_t prefetchQueueLimit() const { return mQueueLimit; }

  /// The decoded brick `key`, from the cache or decoded now. Concurrent gets of a key that is not resident share
  /// one decode. Throws InputError if the store has no such brick, and CorruptStoreError (to every caller waiting
  /// on that decode) if its frame is corrupt; a failed decode is not remembered, so a later get retries it.
  BrickHandle get(const BrickKey& key);

  /// Whether get(key) would return without touching the disk: the brick is resident or not stored. A decode in
  /// flight does not count (get would wait for it). Throws InputError if the store has no such brick.
  bool ready(const BrickKey& key) const;

  /// Queues `keys` for the worker threads to decode into the cache, in order, skipping keys that are resident,
  /// in flight, already queued, empty, not in the store, or larger than the budget. Never blocks on a decode.
  void prefetch(std::span<const BrickKey> keys);
  /// Discards every queued prefetch request (decodes already running finish and are cached).
  void cancelPrefetch();

  /// A snapshot of the counters.
  CacheStats stats() const;
  /// The keys the cache holds now, protected segment first, each segment most recently used first.
  std::vector<BrickKey> residentKeys() const;

 private:
  enum class Segment : uint8_t { Probation, Protected };

  struct Entry {
    BrickHandle brick;
    Segment segment = Segment::Probation;
    std::list<BrickKey>::iterator pos;
    bool prefetchedUnused = false;  // loaded by a prefetch, not yet returned by a get
  };

  using SharedBrick = std::shared_future<BrickHandle>;

  BrickHandle emptyBrick(const BrickKey& key);
  BrickHandle decode(const BrickKey& key);
  // Decodes `key`, whose in-flight marker this thread registered, caches it and fulfils `promise`.
  BrickHandle load(const BrickKey& key, std::promise<BrickHandle>& promise, bool byPrefetch);
  void touchLocked(Entry& entry);
  void insertLocked(const BrickKey& key, const BrickHandle& brick, bool byPrefetch);
  void evictOneLocked();
  void demoteLocked();
  void workerLoop();

  const std::shared_ptr<const BrickStore> mStore;
  size_t mBudget;           // guarded by mMutex
  size_t mProtectedBudget;  // guarded by mMutex
  const size_t mQueueLimit;
  const size_t mBrickBytes;
  const int mWorkerCount;
  const std::shared_ptr<Brick::LiveBytes> mLive;

  mutable std::mutex mMutex;
  std::shared_ptr<const std::byte[]> mBackground;  // filled on the first empty get
  std::condition_variable mWork;
  bool mStopping = false;
  std::unordered_map<BrickKey, Entry> mEntries;
  std::list<BrickKey> mProbation;  // most recently used first
  std::list<BrickKey> mProtected;  // most recently used first
  size_t mProtectedBytes = 0;
  std::unordered_map<BrickKey, SharedBrick> mInFlight;
  std::deque<BrickKey> mQueue;
  std::unordered_set<BrickKey> mQueued;
  CacheStats mStats;  // counters and residency; live bytes come from mLive

  std::vector<std::thread> mWorkers;
};

}  // namespace voxbrick::store
