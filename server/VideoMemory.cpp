// The video encoders' memory: reservations, and the idle encoders freed for a new one.
#include "server/VideoMemory.h"

#include <algorithm>
#include <vector>

namespace voxbrick::server {

bool VideoMemory::reserve(Holder& holder, uint64_t bytes, Clock::time_point now) {
  std::lock_guard lock(mMutex);
  if (const auto mine = mEntries.find(&holder); mine != mEntries.end()) {
    mBytes -= mine->second.bytes;
    mEntries.erase(mine);
  }
  if (mBytes + bytes > mLimit) {
    // The streams at rest, least recently used first.
    std::vector<std::pair<Clock::time_point, Holder*>> idle;
    for (const auto& [other, entry] : mEntries)
      if (entry.lastUse + kIdleMs <= now) idle.emplace_back(entry.lastUse, other);
    std::sort(idle.begin(), idle.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [lastUse, other] : idle) {
      if (mBytes + bytes <= mLimit) break;
      if (!other->freeEncoder()) continue;  // it began a frame meanwhile
      const auto entry = mEntries.find(other);
      mBytes -= entry->second.bytes;
      mEntries.erase(entry);
      ++mFreed;
    }
    if (mBytes + bytes > mLimit) {
      ++mRefused;
      return false;
    }
  }
  mEntries[&holder] = Entry{bytes, now};
  mBytes += bytes;
  mPeak = std::max(mPeak, mBytes);
  return true;
}

void VideoMemory::used(Holder& holder, Clock::time_point now) {
  std::lock_guard lock(mMutex);
  if (const auto mine = mEntries.find(&holder); mine != mEntries.end()) mine->second.lastUse = now;
}

void VideoMemory::release(Holder& holder) {
  std::lock_guard lock(mMutex);
  if (const auto mine = mEntries.find(&holder); mine != mEntries.end()) {
    mBytes -= mine->second.bytes;
    mEntries.erase(mine);
  }
}

uint64_t VideoMemory::bytes() const {
  std::lock_guard lock(mMutex);
  return mBytes;
}

uint64_t VideoMemory::peakBytes() const {
  std::lock_guard lock(mMutex);
  return mPeak;
}

size_t VideoMemory::encoders() const {
  std::lock_guard lock(mMutex);
  return mEntries.size();
}

size_t VideoMemory::moving(Clock::time_point now) const {
  std::lock_guard lock(mMutex);
  return size_t(std::count_if(mEntries.begin(), mEntries.end(),
                              [now](const auto& entry) { return entry.second.lastUse + kIdleMs > now; }));
}

double VideoMemory::msForAMegapixel(proto::Encoding codec, bool fullChroma) const {
  std::lock_guard lock(mMutex);
  return mMsForAMegapixel[size_t(costKind(codec, fullChroma))];
}

void VideoMemory::measured(proto::Encoding codec, bool fullChroma, double msForAMegapixel) {
  std::lock_guard lock(mMutex);
  mMsForAMegapixel[size_t(costKind(codec, fullChroma))] = msForAMegapixel;
}

uint64_t VideoMemory::freed() const {
  std::lock_guard lock(mMutex);
  return mFreed;
}

uint64_t VideoMemory::refused() const {
  std::lock_guard lock(mMutex);
  return mRefused;
}

}  // namespace voxbrick::server
