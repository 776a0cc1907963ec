// Which brick occupies which slot of the GPU brick atlas: LRU replacement with per-batch pinning. No GL.
#pragma once

#include <cstdint>
#include <list>
#include <optional>
#include <unordered_map>
#include <vector>

#include "brickstore/format/Types.h"

namespace voxbrick::render {

/// A slot index of the atlas, distinct from other integers.
struct AtlasSlot {
  int index = -1;
  bool operator==(const AtlasSlot&) const = default;
};

/// Slot bookkeeping for an atlas of `capacity` slots. A frame acquires slots for its bricks in visibility order;
/// a slot acquired in the current batch is pinned (its brick is about to be drawn) and never given to another
/// brick until unpinAll(). When every slot is pinned, acquire() answers nothing: the caller draws the batch,
/// unpins, and goes on, so a frame needing more bricks than the atlas holds still renders, batch by batch.
class AtlasSlots {
 public:
  explicit AtlasSlots(int capacity);

  struct Acquired {
    AtlasSlot slot;
    bool resident = false;                   ///< the brick was already in the slot: no upload needed
    std::optional<store::BrickKey> evicted;  ///< the brick that lost the slot, if any
  };

  /// The slot for `key`, pinned; std::nullopt if it is not resident and every slot is pinned.
  std::optional<Acquired> acquire(const store::BrickKey& key);
  /// Ends a batch: every slot may be replaced again.
  void unpinAll();
  /// Forgets every brick (e.g. when the atlas texture is recreated).
  void clear();
  /// Forgets `key` (its slot is empty again, e.g. when the upload into it failed); nothing if it is not resident.
  void forget(const store::BrickKey& key);

  int capacity() const { return static_cast<int>(mSlots.size()); }
  int pinned() const { return mPinnedCount; }
  /// True if `key` is in some slot.
  bool resident(const store::BrickKey& key) const { return mWhere.count(key) != 0; }
  /// Counts changes of which brick is in which slot (a brick given a slot, forgotten, or every brick cleared): while
  /// it stays the same, every resident brick is where it was.
  uint64_t generation() const { return mGeneration; }

 private:
  struct Slot {
    std::optional<store::BrickKey> key;
    bool pinned = false;
    std::list<int>::iterator lru;  // position in mLru
  };
  std::vector<Slot> mSlots;
  std::list<int> mLru;  // least recently used first
  std::unordered_map<store::BrickKey, int> mWhere;
  int mPinnedCount = 0;
  uint64_t mGeneration = 0;
};

}  // namespace voxbrick::render
