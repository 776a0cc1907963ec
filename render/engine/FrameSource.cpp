// What the frame sources share.
#include "render/engine/FrameSource.h"

#include <algorithm>
#include <string>
#include <thread>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

double checkedPixelSamples(const std::shared_ptr<const Dataset>& dataset, const Scene& scene,
                           const FrameOptions& options) {
  if (!dataset) throw RenderInputError("no dataset");
  const double samples = double(scene.width) * double(scene.height);
  if (options.maxSamples > 0 && samples > options.maxSamples)
    throw RenderLimitError("the frame would take " + std::to_string(samples) + " samples, above the limit of " +
                           std::to_string(options.maxSamples));
  return samples;
}

void spendDrawingTime(std::chrono::steady_clock::time_point end, const FrameOptions& options) {
  for (;;) {
    if (options.cancelled && options.cancelled()) throw FrameCancelled("the frame was given up");
    const auto now = std::chrono::steady_clock::now();
    if (now >= end) return;
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(end - now, std::chrono::milliseconds(1)));
  }
}

}  // namespace voxbrick::render
