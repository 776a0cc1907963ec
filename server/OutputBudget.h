// The bytes of replies queued for every session together (limits.max_total_output_bytes): sessions on any I/O
// thread add what they queue and release what they wrote, so clients that do not read cannot grow the server
// without bound between them.
#pragma once

#include <atomic>
#include <cstdint>

namespace voxbrick::server {

class OutputBudget {
 public:
  explicit OutputBudget(uint64_t limit) : mLimit(limit) {}

  /// Whether `bytes` more may be queued: they fit under the limit, or nothing is queued at all (so a frame larger
  /// than the limit still goes out once the others are written). Advisory: sessions check and add without a lock,
  /// so several at once may pass it by a reply each.
  bool fits(uint64_t bytes) const {
    const uint64_t queued = mQueued.load(std::memory_order_relaxed);
    return queued == 0 || queued + bytes <= mLimit;
  }
  void add(uint64_t bytes) {
    const uint64_t now = mQueued.fetch_add(bytes, std::memory_order_relaxed) + bytes;
    uint64_t peak = mPeak.load(std::memory_order_relaxed);
    while (now > peak && !mPeak.compare_exchange_weak(peak, now, std::memory_order_relaxed)) {
    }
  }
  void release(uint64_t bytes) { mQueued.fetch_sub(bytes, std::memory_order_relaxed); }

  uint64_t queued() const { return mQueued.load(std::memory_order_relaxed); }
  uint64_t peak() const { return mPeak.load(std::memory_order_relaxed); }
  uint64_t limit() const { return mLimit; }

 private:
  const uint64_t mLimit;
  std::atomic<uint64_t> mQueued{0}, mPeak{0};
};

}  // namespace voxbrick::server
