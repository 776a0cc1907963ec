// The reference renderer's bricks: each fetched once from the host cache and held for the renderer's lifetime.
#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <vector>

#include "brickstore/read/BrickCache.h"

namespace voxbrick::render {

/// Level-0 bricks, fetched from the cache on first use by any thread and held for the renderer's lifetime, so a
/// sample costs one atomic load instead of a cache lookup.
class ReferenceBricks {
 public:
  explicit ReferenceBricks(std::shared_ptr<store::BrickCache> cache) : mCache(std::move(cache)) {
    // One pointer per brick of every level, level after level.
    mCount = 0;
    for (int l = 0; l < mCache->store()->levelCount(); ++l) {
      mLevelFirst.push_back(mCount);
      mCount += size_t(mCache->store()->level(l).bricksTotal());
    }
    mPointers = std::make_unique<std::atomic<const void*>[]>(mCount);
    for (size_t i = 0; i < mCount; ++i) mPointers[i].store(nullptr, std::memory_order_relaxed);
  }

  /// The index of `key`'s pointer from its index within its level.
  size_t index(const store::BrickKey& key, size_t inLevel) const { return mLevelFirst[key.level] + inLevel; }

  const void* data(const store::BrickKey& key, size_t index) {
    const void* p = mPointers[index].load(std::memory_order_acquire);
    return p ? p : load(key, index);
  }

 private:
  const void* load(const store::BrickKey& key, size_t index) {
    store::BrickHandle brick = mCache->get(key);
    std::lock_guard lock(mMutex);
    if (const void* p = mPointers[index].load(std::memory_order_relaxed)) return p;
    mPointers[index].store(brick->data(), std::memory_order_release);
    mHandles.push_back(std::move(brick));
    return mHandles.back()->data();
  }

  std::shared_ptr<store::BrickCache> mCache;
  size_t mCount;
  std::vector<size_t> mLevelFirst;
  std::unique_ptr<std::atomic<const void*>[]> mPointers;
  std::mutex mMutex;
  std::vector<store::BrickHandle> mHandles;
};

}  // namespace voxbrick::render
