// The frame source that draws nothing.
#include "render/engine/NullFrameSource.h"

#include <algorithm>
#include <thread>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

image::ImageF NullFrameSource::render(const std::shared_ptr<const Dataset>& dataset, const Scene& scene,
                                      FrameStats* stats, const FrameOptions& options) {
  checkedPixelSamples(dataset, scene, options);
  double warmupMs = 0;
  if (const int64_t warmup = mWarmup.exchange(0); warmup > 0) {
    const auto warmupStart = std::chrono::steady_clock::now();
    std::this_thread::sleep_for(std::chrono::microseconds(warmup));
    warmupMs = msSince(warmupStart);
  }
  const auto start = std::chrono::steady_clock::now();
  const auto end = start + mDrawTime + mPerPixel * (int64_t(scene.width) * int64_t(scene.height));
  spendDrawingTime(end, options);
  image::ImageF image{scene.width, scene.height,
                      std::vector<float>(size_t(scene.width) * size_t(scene.height) * 4, 0.0f)};
  const float alpha = scene.transparent ? 0.0f : 1.0f;
  for (size_t i = 0; i < image.rgba.size(); i += 4) {
    image.rgba[i] = scene.transparent ? 0.0f : float(scene.background.r);
    image.rgba[i + 1] = scene.transparent ? 0.0f : float(scene.background.g);
    image.rgba[i + 2] = scene.transparent ? 0.0f : float(scene.background.b);
    image.rgba[i + 3] = alpha;
  }
  const double ms = msSince(start);
  if (stats) {
    *stats = {};
    stats->samplesEstimated = std::max(ms, 1e-3) * mSamplesPerMs;
    stats->msTotal = ms;
    stats->msWarmup = warmupMs;
  }
  {
    std::lock_guard lock(mMutex);
    mWidths.push_back(scene.width);
  }
  ++mDrawn;
  return image;
}

void NullFrameSource::prefetch(const std::shared_ptr<const Dataset>&, const Scene&) {
  if (const int64_t us = mPrefetchTime.load(); us > 0) std::this_thread::sleep_for(std::chrono::microseconds(us));
  ++mPrefetches;
}

}  // namespace voxbrick::render
