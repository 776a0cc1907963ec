// The bounded host cache of decoded bricks: segmented LRU residency, shared in-flight decodes, prefetch workers.
#include "brickstore/read/BrickCache.h"

#include <atomic>
#include <new>
#include <string>
#include <utility>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {

/// Decoded bytes alive anywhere, shared by the cache and its bricks so that bricks may outlive the cache.
struct Brick::LiveBytes {
  std::atomic<size_t> live{0};
  std::atomic<size_t> peak{0};

  void add(size_t n) {
    const size_t now = live.fetch_add(n, std::memory_order_relaxed) + n;
    size_t seen = peak.load(std::memory_order_relaxed);
    while (now > seen && !peak.compare_exchange_weak(seen, now, std::memory_order_relaxed)) {
    }
  }
  void sub(size_t n) { live.fetch_sub(n, std::memory_order_relaxed); }
};

Brick::~Brick() {
  if (mLive) mLive->sub(mBytes);
}

BrickCache::BrickCache(std::shared_ptr<const BrickStore> store, size_t budgetBytes, int prefetchThreads,
                       size_t prefetchQueueLimit)
    : mStore(std::move(store)),
      mBudget(budgetBytes),
      // 80% for the protected segment leaves probation room for new bricks without touching the hot set.
      mProtectedBudget(budgetBytes / 5 * 4),
      mQueueLimit(prefetchQueueLimit),
      mBrickBytes(mStore ? mStore->brickBytes() : 0),
      mWorkerCount(prefetchThreads),
      mLive(std::make_shared<Brick::LiveBytes>()) {
  if (!mStore) throw InputError("BrickCache: the store is null");
  if (prefetchThreads < 0)
    throw InputError("BrickCache: prefetchThreads must be >= 0, got " + std::to_string(prefetchThreads));
  if (prefetchQueueLimit == 0) throw InputError("BrickCache: prefetchQueueLimit must be > 0");
  mStats.budgetBytes = mBudget;
  try {
    for (int t = 0; t < prefetchThreads; ++t) mWorkers.emplace_back([this] { workerLoop(); });
  } catch (...) {
    // The destructor will not run for a half-built cache, so the workers already started must be joined here.
    {
      std::lock_guard lock(mMutex);
      mStopping = true;
    }
    mWork.notify_all();
    for (auto& worker : mWorkers) worker.join();
    throw;
  }
}

BrickCache::~BrickCache() {
  {
    std::lock_guard lock(mMutex);
    mStopping = true;
    mStats.prefetchDrops += mQueue.size();
    mQueue.clear();
    mQueued.clear();
  }
  mWork.notify_all();
  for (auto& worker : mWorkers) worker.join();
}

BrickHandle BrickCache::get(const BrickKey& key) {
  // isStored() throws InputError for a key outside the store, which is what get promises.
  if (!mStore->isStored(key)) return emptyBrick(key);

  std::unique_lock lock(mMutex);
  if (auto it = mEntries.find(key); it != mEntries.end()) {
    ++mStats.hits;
    touchLocked(it->second);
    return it->second.brick;
  }
  ++mStats.misses;
  if (auto it = mInFlight.find(key); it != mInFlight.end()) {
    SharedBrick pending = it->second;
    lock.unlock();
    BrickHandle brick = pending.get();  // rethrows the decode's error to every waiter
    // This get is the first use of a brick a prefetch was loading: it must not count as a later prefetch hit.
    lock.lock();
    if (auto e = mEntries.find(key); e != mEntries.end()) e->second.prefetchedUnused = false;
    return brick;
  }
  std::promise<BrickHandle> promise;
  mInFlight.emplace(key, promise.get_future().share());
  lock.unlock();
  return load(key, promise, false);
}

size_t BrickCache::budgetBytes() const {
  std::lock_guard lock(mMutex);
  return mBudget;
}

void BrickCache::setBudget(size_t budgetBytes) {
  std::lock_guard lock(mMutex);
  mBudget = budgetBytes;
  mProtectedBudget = budgetBytes / 5 * 4;
  mStats.budgetBytes = budgetBytes;
  while (mStats.residentBytes > mBudget) evictOneLocked();
  demoteLocked();
}

bool BrickCache::ready(const BrickKey& key) const {
  if (!mStore->isStored(key)) return true;
  std::lock_guard lock(mMutex);
  return mEntries.contains(key);
}

void BrickCache::prefetch(std::span<const BrickKey> keys) {
  if (keys.empty()) return;
  std::unique_lock lock(mMutex);
  mStats.prefetchRequests += keys.size();
  if (mWorkerCount == 0) {
    mStats.prefetchDrops += keys.size();
    return;
  }
  size_t queued = 0;
  for (const BrickKey& key : keys) {
    // Prefetch is advisory, so keys the renderer computed past a volume's edge are ignored rather than thrown on.
    if (!mStore->contains(key) || !mStore->isStored(key) || mBrickBytes > mBudget) continue;
    if (mEntries.contains(key) || mInFlight.contains(key) || mQueued.contains(key)) continue;
    if (mQueue.size() >= mQueueLimit) {
      mQueued.erase(mQueue.front());
      mQueue.pop_front();
      ++mStats.prefetchDrops;
    }
    mQueue.push_back(key);
    mQueued.insert(key);
    ++queued;
  }
  lock.unlock();
  if (queued == 1)
    mWork.notify_one();
  else if (queued > 1)
    mWork.notify_all();
}

void BrickCache::cancelPrefetch() {
  std::lock_guard lock(mMutex);
  mStats.prefetchDrops += mQueue.size();
  mQueue.clear();
  mQueued.clear();
}

CacheStats BrickCache::stats() const {
  std::lock_guard lock(mMutex);
  CacheStats s = mStats;
  s.prefetchQueued = mQueue.size();
  s.inFlight = mInFlight.size();
  s.residentBricks = mEntries.size();
  s.liveBytes = mLive->live.load(std::memory_order_relaxed);
  s.peakLiveBytes = mLive->peak.load(std::memory_order_relaxed);
  return s;
}

std::vector<BrickKey> BrickCache::residentKeys() const {
  std::lock_guard lock(mMutex);
  std::vector<BrickKey> keys;
  keys.reserve(mEntries.size());
  keys.insert(keys.end(), mProtected.begin(), mProtected.end());
  keys.insert(keys.end(), mProbation.begin(), mProbation.end());
  return keys;
}

BrickHandle BrickCache::emptyBrick(const BrickKey& key) {
  std::shared_ptr<const std::byte[]> background;
  {
    std::lock_guard lock(mMutex);
    ++mStats.emptyGets;
    if (!mBackground) {
      // The store fills a brick it does not hold with its background without touching the disk; asking it (once)
      // keeps the background's conversion to the value type in one place.
      std::shared_ptr<std::byte[]> samples(new std::byte[mBrickBytes]);
      mStore->readBrick(key, samples.get());
      mBackground = std::move(samples);
    }
    background = mBackground;
  }
  std::shared_ptr<Brick> brick(new Brick());
  brick->mKey = key;
  brick->mBytes = mBrickBytes;
  brick->mType = mStore->type();
  brick->mEmpty = true;
  brick->mBackground = std::move(background);
  brick->mData = brick->mBackground.get();
  return brick;
}

BrickHandle BrickCache::decode(const BrickKey& key) {
  std::shared_ptr<Brick> brick(new Brick());
  brick->mKey = key;
  brick->mBytes = mBrickBytes;
  brick->mType = mStore->type();
  brick->mOwned.reset(new std::byte[mBrickBytes]);
  brick->mData = brick->mOwned.get();
  mLive->add(mBrickBytes);
  brick->mLive = mLive;
  // A store that builds coarse bricks from finer ones gets those through this cache, so each is built once.
  mStore->readBrick(key, brick->mOwned.get(), [this](const BrickKey& finer) {
    BrickHandle samples = get(finer);
    return std::shared_ptr<const void>(samples, samples->data());
  });
  return brick;
}

BrickHandle BrickCache::load(const BrickKey& key, std::promise<BrickHandle>& promise, bool byPrefetch) {
  BrickHandle brick;
  try {
    brick = decode(key);
  } catch (...) {
    // Forget the failed decode before waking the waiters, so that a later get retries instead of seeing it.
    {
      std::lock_guard lock(mMutex);
      mInFlight.erase(key);
      ++mStats.decodeErrors;
    }
    promise.set_exception(std::current_exception());
    throw;
  }
  {
    std::lock_guard lock(mMutex);
    mInFlight.erase(key);
    ++mStats.bricksDecoded;
    mStats.bytesDecoded += brick->bytes();
    try {
      insertLocked(key, brick, byPrefetch);
    } catch (const std::bad_alloc&) {
      // Caching is an optimisation: without room for the bookkeeping the brick is still handed out, uncached.
    }
  }
  promise.set_value(brick);
  return brick;
}

void BrickCache::touchLocked(Entry& entry) {
  if (entry.prefetchedUnused) {
    // The first get of a prefetched brick is its first use, not a repeat one: it stays in probation.
    entry.prefetchedUnused = false;
    ++mStats.prefetchHits;
    mProbation.splice(mProbation.begin(), mProbation, entry.pos);
    return;
  }
  if (entry.segment == Segment::Protected) {
    mProtected.splice(mProtected.begin(), mProtected, entry.pos);
    return;
  }
  mProtected.splice(mProtected.begin(), mProbation, entry.pos);
  entry.segment = Segment::Protected;
  mProtectedBytes += entry.brick->bytes();
  demoteLocked();
}

void BrickCache::demoteLocked() {
  while (mProtectedBytes > mProtectedBudget && !mProtected.empty()) {
    Entry& demoted = mEntries.at(mProtected.back());
    mProbation.splice(mProbation.begin(), mProtected, demoted.pos);
    demoted.segment = Segment::Probation;
    mProtectedBytes -= demoted.brick->bytes();
  }
}

void BrickCache::insertLocked(const BrickKey& key, const BrickHandle& brick, bool byPrefetch) {
  const size_t bytes = brick->bytes();
  if (bytes > mBudget || mEntries.contains(key)) return;
  // Evict first: residency must stay within the budget at every instant, not just after the insert.
  while (mStats.residentBytes + bytes > mBudget) evictOneLocked();
  mProbation.push_front(key);
  try {
    Entry entry;
    entry.brick = brick;
    entry.segment = Segment::Probation;
    entry.pos = mProbation.begin();
    entry.prefetchedUnused = byPrefetch;
    mEntries.emplace(key, std::move(entry));
  } catch (...) {
    mProbation.pop_front();
    throw;
  }
  mStats.residentBytes += bytes;
  if (mStats.residentBytes > mStats.peakResidentBytes) mStats.peakResidentBytes = mStats.residentBytes;
}

void BrickCache::evictOneLocked() {
  const bool fromProbation = !mProbation.empty();
  const BrickKey victim = fromProbation ? mProbation.back() : mProtected.back();
  auto it = mEntries.find(victim);
  const size_t bytes = it->second.brick->bytes();
  if (fromProbation) {
    mProbation.pop_back();
  } else {
    mProtected.pop_back();
    mProtectedBytes -= bytes;
  }
  mEntries.erase(it);
  mStats.residentBytes -= bytes;
  ++mStats.evictions;
}

void BrickCache::workerLoop() {
  std::unique_lock lock(mMutex);
  for (;;) {
    mWork.wait(lock, [this] { return mStopping || !mQueue.empty(); });
    if (mStopping) return;
    const BrickKey key = mQueue.front();
    mQueue.pop_front();
    mQueued.erase(key);
    // A get may have loaded or started the brick since it was queued.
    if (mEntries.contains(key) || mInFlight.contains(key)) continue;
    std::promise<BrickHandle> promise;
    mInFlight.emplace(key, promise.get_future().share());
    lock.unlock();
    try {
      load(key, promise, true);
    } catch (...) {
      // A failed prefetch is not fatal: any get waiting on it received the error, and decodeErrors counts it.
    }
    lock.lock();
  }
}

}  // namespace voxbrick::store
