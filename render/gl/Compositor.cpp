// The frame's float target, blending state and readback.
#include "render/gl/Compositor.h"

#include <algorithm>
#include <chrono>

#include "render/core/FrameStats.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

Compositor::Compositor(const Gl& gl) : mGl(gl), mFragments(gl) {}

void Compositor::begin(int width, int height, bool blend, bool silhouette) {
  if (mTarget.width() != width || mTarget.height() != height) {
    mTarget = Framebuffer::withColor(mGl, width, height, GL_RGBA32F);
    mDepth.reset();
    mDepthOnly.reset();
  }
  if (silhouette && !mDepth) {
    mDepth = Texture(mGl, GL_TEXTURE_2D);
    mGl.glBindTexture(GL_TEXTURE_2D, mDepth.id());
    mGl.glTexStorage2D(GL_TEXTURE_2D, 1, GL_DEPTH_COMPONENT32F, width, height);
    mGl.glBindFramebuffer(GL_FRAMEBUFFER, mTarget.id());
    mGl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, mDepth.id(), 0);
    mTarget.checkComplete("Compositor: target with silhouette map");
    mDepthOnly = Framebuffer(mGl);
    mGl.glBindFramebuffer(GL_FRAMEBUFFER, mDepthOnly.id());
    mGl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, mDepth.id(), 0);
    const GLenum none = GL_NONE;
    mGl.glDrawBuffers(1, &none);
    mGl.glReadBuffer(GL_NONE);
    mDepthOnly.checkComplete("Compositor: silhouette map");
  }
  mTarget.bind();
  const float zero[4] = {0, 0, 0, 0};
  mGl.glClearBufferfv(GL_COLOR, 0, zero);
  if (silhouette) {
    const float one = 1;
    mGl.glDepthMask(GL_TRUE);
    mGl.glClearBufferfv(GL_DEPTH, 0, &one);
    mGl.glDepthMask(GL_FALSE);
    mGl.glEnable(GL_DEPTH_TEST);
    mGl.glDepthFunc(GL_LESS);
  } else {
    mGl.glDisable(GL_DEPTH_TEST);
  }
  mGl.glDisable(GL_CULL_FACE);
  if (blend)
    mGl.glEnable(GL_BLEND);
  else
    mGl.glDisable(GL_BLEND);
  mGl.glBlendEquation(GL_FUNC_ADD);
  mGl.glBlendFuncSeparate(GL_ONE_MINUS_DST_ALPHA, GL_ONE, GL_ONE_MINUS_DST_ALPHA, GL_ONE);
  mGl.glBeginQuery(GL_SAMPLES_PASSED, mFragments.id());
  mCounting = true;
}

void Compositor::abort() {
  if (mCounting) mGl.glEndQuery(GL_SAMPLES_PASSED);
  mCounting = false;
  mGl.glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  mGl.glDepthMask(GL_FALSE);
  mGl.glDepthRange(0, 1);
  mGl.glDepthFunc(GL_LESS);
  mGl.glDisable(GL_DEPTH_TEST);
  mGl.glDisable(GL_BLEND);
  mGl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void Compositor::bindSilhouette() const {
  mGl.glBindFramebuffer(GL_FRAMEBUFFER, mDepthOnly.id());
  mGl.glViewport(0, 0, mTarget.width(), mTarget.height());
}

void Compositor::bindImage(GLuint unit) const {
  mGl.glBindImageTexture(unit, mTarget.color().id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_RGBA32F);
}

image::ImageF Compositor::finish(const Scene& scene, FrameStats& stats, bool premultiplied) {
  mGl.glEndQuery(GL_SAMPLES_PASSED);
  mCounting = false;
  mGl.glDisable(GL_DEPTH_TEST);
  auto t = Clock::now();
  mGl.glFinish();
  stats.msDrawing += msSince(t);
  stats.fragments = int64_t(mFragments.result());
  t = Clock::now();
  mTarget.readRgba(mRaw);
  const std::vector<float>& raw = mRaw;
  const int width = mTarget.width(), height = mTarget.height();
  image::ImageF image{width, height, std::vector<float>(raw.size())};
  for (int y = 0; y < height; ++y) {
    const float* src = raw.data() + size_t(height - 1 - y) * size_t(width) * 4;
    float* dst = image.pixel(0, y);
    if (premultiplied) {
      std::copy_n(src, size_t(width) * 4, dst);
      continue;
    }
    for (int x = 0; x < width; ++x, src += 4, dst += 4) {
      if (scene.transparent) {
        const glm::dvec4 out = scene.output({src[0], src[1], src[2]}, src[3]);
        for (int c = 0; c < 4; ++c) dst[c] = float(out[c]);
        continue;
      }
      // Scene::output in float, as the opaque frames have always been computed (bit for bit: the golden frames).
      const float a = std::clamp(src[3], 0.0f, 1.0f);
      for (int c = 0; c < 3; ++c) dst[c] = std::clamp(src[c] + (1 - a) * float(scene.background[c]), 0.0f, 1.0f);
      dst[3] = 1;
    }
  }
  stats.msReadback = msSince(t);
  return image;
}

}  // namespace voxbrick::render
