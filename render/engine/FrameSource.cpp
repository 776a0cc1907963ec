// What the frame sources share.
#include "render/engine/FrameSource.h"

#include <algorithm>
#include <thread>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

void spendDrawingTime(std::chrono::steady_clock::time_point end, const FrameOptions& options) {
  for (;;) {
    if (options.cancelled && options.cancelled()) throw FrameCancelled("the frame was given up");
    const auto now = std::chrono::steady_clock::now();
    if (now >= end) return;
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(end - now, std::chrono::milliseconds(1)));
  }
}

}  // namespace voxbrick::render
