// The frame's float target, blending state and readback.
#include "render/Compositor.h"

#include <algorithm>
#include <chrono>

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

}  // namespace

Compositor::Compositor(const Gl& gl) : mGl(gl), mFragments(gl) {}

void Compositor::begin(int width, int height, bool blend) {
  if (mTarget.width() != width || mTarget.height() != height)
    mTarget = Framebuffer::withColor(mGl, width, height, GL_RGBA32F);
  mTarget.bind();
  const float zero[4] = {0, 0, 0, 0};
  mGl.glClearBufferfv(GL_COLOR, 0, zero);
  mGl.glDisable(GL_DEPTH_TEST);
  mGl.glDisable(GL_CULL_FACE);
  if (blend)
    mGl.glEnable(GL_BLEND);
  else
    mGl.glDisable(GL_BLEND);
  mGl.glBlendEquation(GL_FUNC_ADD);
  mGl.glBlendFuncSeparate(GL_ONE_MINUS_DST_ALPHA, GL_ONE, GL_ONE_MINUS_DST_ALPHA, GL_ONE);
  mGl.glBeginQuery(GL_SAMPLES_PASSED, mFragments.id());
}

image::ImageF Compositor::finish(const glm::dvec3& background, FrameStats& stats) {
  mGl.glEndQuery(GL_SAMPLES_PASSED);
  auto t = Clock::now();
  mGl.glFinish();
  stats.msDrawing += msSince(t);
  stats.fragments = int64_t(mFragments.result());
  t = Clock::now();
  const std::vector<float> raw = mTarget.readRgba();
  const int width = mTarget.width(), height = mTarget.height();
  image::ImageF image{width, height, std::vector<float>(raw.size())};
  for (int y = 0; y < height; ++y) {
    const float* src = raw.data() + size_t(height - 1 - y) * size_t(width) * 4;
    float* dst = image.pixel(0, y);
    for (int x = 0; x < width; ++x, src += 4, dst += 4) {
      const float a = std::clamp(src[3], 0.0f, 1.0f);
      for (int c = 0; c < 3; ++c) dst[c] = std::clamp(src[c] + (1 - a) * float(background[c]), 0.0f, 1.0f);
      dst[3] = 1;
    }
  }
  stats.msReadback = msSince(t);
  return image;
}

}  // namespace voxbrick::render
