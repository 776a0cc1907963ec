// A frame source that draws nothing and needs no GL: each frame is the scene's background at its size, after a set
// time of "drawing" that a cancelled frame gives up. What the scheduler and the server above it are tested with
// when no GPU, no context and no real dataset matter (latest wins, superseding, coalescing, cancellation,
// fairness). GL-free.
#pragma once

#include <atomic>
#include <chrono>
#include <mutex>
#include <string>
#include <vector>

#include "render/engine/FrameSource.h"

namespace voxbrick::render {

class NullFrameSource final : public FrameSource {
 public:
  /// Every frame takes `drawTime` plus `perPixel` times its width times height (slept in steps of at most 1 ms,
  /// asking FrameOptions::cancelled between them) and is reported as `samplesPerMs` times its time in estimated
  /// samples.
  explicit NullFrameSource(std::chrono::microseconds drawTime = std::chrono::microseconds(0),
                           double samplesPerMs = 1000, std::chrono::nanoseconds perPixel = std::chrono::nanoseconds(0))
      : mDrawTime(drawTime), mSamplesPerMs(samplesPerMs), mPerPixel(perPixel) {}

  std::string describe() const override { return "null frame source (draws nothing)"; }
  /// The scene's background, opaque (or transparent with a transparent background), at its size. Throws
  /// RenderInputError without a dataset, RenderLimitError when the frame's width times height is above
  /// options.maxSamples (its "estimate"), FrameCancelled when options.cancelled says so.
  image::ImageF render(const std::shared_ptr<const Dataset>& dataset, const Scene& scene, FrameStats* stats = nullptr,
                       const FrameOptions& options = {}) override;
  void prefetch(const std::shared_ptr<const Dataset>& dataset, const Scene& scene) override;

  /// The next frame first spends `time` as a renderer's one-time making would (not cancellable), reported as its
  /// FrameStats::msWarmup, outside msTotal; the frames after it do not.
  void warmUpNextFrame(std::chrono::microseconds time) { mWarmup.store(time.count()); }

  /// Each prefetch from now on takes `time` (as paging ahead plans the next camera's bricks on the render thread).
  void prefetchTakes(std::chrono::microseconds time) { mPrefetchTime.store(time.count()); }

  /// Frames drawn (not cancelled), and prefetches asked for, so far. Any thread may ask.
  uint64_t framesDrawn() const { return mDrawn.load(); }
  uint64_t prefetches() const { return mPrefetches.load(); }
  /// The widths of the frames drawn, in order (tests tell requests apart by their sizes).
  std::vector<int> widthsDrawn() const {
    std::lock_guard lock(mMutex);
    return mWidths;
  }

 private:
  std::chrono::microseconds mDrawTime;
  double mSamplesPerMs;
  std::chrono::nanoseconds mPerPixel;
  std::atomic<uint64_t> mDrawn{0}, mPrefetches{0};
  std::atomic<int64_t> mWarmup{0};        ///< microseconds of warm-up the next frame takes
  std::atomic<int64_t> mPrefetchTime{0};  ///< microseconds each prefetch takes
  mutable std::mutex mMutex;
  std::vector<int> mWidths;
};

}  // namespace voxbrick::render
