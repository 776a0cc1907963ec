// LRU slot replacement for the brick atlas.
#include "render/volume/AtlasSlots.h"

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

AtlasSlots::AtlasSlots(int capacity) {
  if (capacity < 1) throw RenderInputError("AtlasSlots: capacity " + std::to_string(capacity) + " < 1");
  mSlots.resize(static_cast<size_t>(capacity));
  for (int s = 0; s < capacity; ++s) mSlots[size_t(s)].lru = mLru.insert(mLru.end(), s);
}

std::optional<AtlasSlots::Acquired> AtlasSlots::acquire(const store::BrickKey& key) {
  Acquired result;
  int index;
  if (auto it = mWhere.find(key); it != mWhere.end()) {
    index = it->second;
    result.resident = true;
  } else {
    // The least recently used unpinned slot; pinned slots sit at the back of the list, so this is a short scan
    // unless nearly all slots are pinned.
    auto victim = mLru.begin();
    while (victim != mLru.end() && mSlots[size_t(*victim)].pinned) ++victim;
    if (victim == mLru.end()) return std::nullopt;
    index = *victim;
    Slot& slot = mSlots[size_t(index)];
    if (slot.key) {
      result.evicted = slot.key;
      mWhere.erase(*slot.key);
    }
    slot.key = key;
    mWhere[key] = index;
    ++mGeneration;
  }
  Slot& slot = mSlots[size_t(index)];
  mLru.splice(mLru.end(), mLru, slot.lru);
  if (!slot.pinned) {
    slot.pinned = true;
    ++mPinnedCount;
  }
  result.slot = AtlasSlot{index};
  return result;
}

void AtlasSlots::unpinAll() {
  if (mPinnedCount == 0) return;  // a frame drawn from a kept table pins nothing: no walk over every slot
  for (Slot& s : mSlots) s.pinned = false;
  mPinnedCount = 0;
}

void AtlasSlots::forget(const store::BrickKey& key) {
  const auto it = mWhere.find(key);
  if (it == mWhere.end()) return;
  Slot& slot = mSlots[size_t(it->second)];
  slot.key.reset();
  mLru.splice(mLru.begin(), mLru, slot.lru);  // the first to be reused
  mWhere.erase(it);
  ++mGeneration;
}

void AtlasSlots::clear() {
  for (Slot& s : mSlots) s.key.reset(), s.pinned = false;
  mWhere.clear();
  mPinnedCount = 0;
  ++mGeneration;
}

}  // namespace voxbrick::render
