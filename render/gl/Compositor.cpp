// The frame's float target, blending state and readback.
#include "render/gl/Compositor.h"

#include <algorithm>
#include <bit>
#include <chrono>

#include "render/core/FrameStats.h"
#include "render/gl/Bindings.h"

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

void Compositor::endPasses(FrameStats& stats) {
  mGl.glEndQuery(GL_SAMPLES_PASSED);
  mCounting = false;
  mGl.glDisable(GL_DEPTH_TEST);
  const auto t = Clock::now();
  mGl.glFinish();
  stats.msDrawing += msSince(t);
  stats.fragments = int64_t(mFragments.result());
}

image::Image8 Compositor::finish8(const Scene& scene, FrameStats& stats) {
  static_assert(std::endian::native == std::endian::little, "finish.comp.glsl packs R in a uint's low byte");
  if (scene.transparent) {
    image::ImageF image = finish(scene, stats);
    const auto t = Clock::now();
    image::Image8 out = image::toImage8(image);
    stats.msReadback += msSince(t);
    return out;
  }
  endPasses(stats);
  const auto t = Clock::now();
  const int width = mTarget.width(), height = mTarget.height();
  if (!mFinish8) {
    mFinish8 = Program(mGl, ProgramSources::fromFiles("finish.comp.glsl", {{GL_COMPUTE_SHADER, "finish.comp.glsl"}}));
    mFinish8Size = mFinish8.requireUniform("uSize");
    mFinish8Background = mFinish8.requireUniform("uBackground");
    mFrame8 = Buffer(mGl);
  }
  const size_t bytes = size_t(width) * size_t(height) * 4;
  if (bytes != mFrame8Bytes) {
    mFrame8.allocate(GL_SHADER_STORAGE_BUFFER, bytes, nullptr, GL_STREAM_READ);
    mFrame8Bytes = bytes;
  }
  mFinish8.use();
  mFinish8.set(mFinish8Size, glm::ivec4(width, height, 0, 0));
  mFinish8.set(mFinish8Background, glm::vec3(scene.background));
  mTarget.color().bind(VB_UNIT_ACCUMULATED);
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_FRAME8, mFrame8.id());
  mGl.glDispatchCompute(GLuint((width + VB_FINISH_GROUP_X - 1) / VB_FINISH_GROUP_X),
                        GLuint((height + VB_FINISH_GROUP_Y - 1) / VB_FINISH_GROUP_Y), 1);
  mGl.glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  image::Image8 out{width, height, std::vector<uint8_t>(bytes)};
  mFrame8.read(0, bytes, out.rgba.data());
  stats.msReadback = msSince(t);
  return out;
}

image::ImageF Compositor::finish(const Scene& scene, FrameStats& stats, bool premultiplied) {
  endPasses(stats);
  const auto t = Clock::now();
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
