// The classes of render work the scheduler tells apart, in the order it serves them: a moving camera's frame and the
// frame that ends a drag (interactive), any other plain Render (still), and work nobody watches as it
// happens (batch: a scene with "batch": true, as `voxbrick load --batch`, `orbit` and scripts send).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "common/EnumNames.h"

namespace voxbrick::server {

enum class FrameClass : uint8_t { Interactive, Still, Batch };
inline constexpr size_t kFrameClasses = 3;

inline constexpr common::EnumName<FrameClass> kFrameClassNames[] = {
    {FrameClass::Interactive, "interactive"}, {FrameClass::Still, "still"}, {FrameClass::Batch, "batch"}};
constexpr std::span<const common::EnumName<FrameClass>> enumNames(FrameClass) { return kFrameClassNames; }

/// Every class, in the order the scheduler serves them.
inline constexpr std::array<FrameClass, kFrameClasses> kAllFrameClasses = {FrameClass::Interactive, FrameClass::Still,
                                                                           FrameClass::Batch};

/// The time one frame may take, ms, for `sessions` sessions (at least one) sharing `threads` threads each to get
/// `fps` frames a second: threads * 1000 / (fps * sessions). The render threads' share of a dragging session
/// (RenderScheduler: its frame's time budget) and the encoder threads' of a moving video stream (VideoStream).
inline double frameShareMs(size_t threads, double fps, size_t sessions) {
  return double(std::max<size_t>(1, threads)) * 1000 / (std::max(1e-3, fps) * double(std::max<size_t>(1, sessions)));
}

/// How a pool of threads is shared between the classes, as the render scheduler and the encoder queue both serve:
/// start-time fair queueing of measured time between classes (a class's tag is its time charged over its weight; the
/// class with the smallest tag goes next, ties to the earlier class; a class that had no work starts again at the tag
/// last served, so time it did not use is not saved up for a burst), and threads kept for interactive work while it
/// comes. Not thread-safe: its owner's lock guards it.
class ClassShares {
 public:
  explicit ClassShares(std::array<double, kFrameClasses> weights) : mWeights(weights) {}

  double weight(FrameClass c) const { return mWeights[size_t(c)]; }
  /// Class `c` has work again after it had none.
  void resume(FrameClass c) { mTag[size_t(c)] = std::max(mTag[size_t(c)], mClock); }
  /// The class to serve among those `ready` (the smallest tag, ties to the earlier class), or -1 if none is; the
  /// clock moves to its tag.
  int pick(const std::array<bool, kFrameClasses>& ready) {
    int chosen = -1;
    for (size_t c = 0; c < kFrameClasses; ++c)
      if (ready[c] && (chosen < 0 || mTag[c] < mTag[size_t(chosen)])) chosen = int(c);
    if (chosen >= 0) mClock = mTag[size_t(chosen)];
    return chosen;
  }
  /// `ms` of class `c`'s work done.
  void charge(FrameClass c, double ms) { mTag[size_t(c)] += ms / mWeights[size_t(c)]; }

  /// Threads of a pool of `threads` kept for interactive work when `reserved` are asked: all but one at most.
  static size_t kept(size_t threads, size_t reserved) { return threads > 0 ? std::min(reserved, threads - 1) : 0; }
  /// Whether still or batch work may start on a pool of `threads` that keeps `kept` for interactive work while
  /// `interactive` (such work comes), with `othersRunning` still and batch tasks running.
  static bool othersMayRun(size_t threads, size_t kept, bool interactive, size_t othersRunning) {
    return !interactive || othersRunning < threads - kept;
  }

 private:
  const std::array<double, kFrameClasses> mWeights;
  std::array<double, kFrameClasses> mTag{};
  double mClock = 0;  ///< the tag of the class served last
};

}  // namespace voxbrick::server
