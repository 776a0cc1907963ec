// Fixtures of the GL rendering suites: one GL context per test binary, frames from the GPU renderer.
#pragma once

#include <memory>

#include "render/RenderFixtures.h"
#include "render/gl/GlContext.h"
#include "render/gl/volume/VolumeRenderer.h"

namespace voxbrick::test {

/// One context for the whole binary: creating a llvmpipe context costs more than most test frames.
inline render::GlContext& context() {
  static std::unique_ptr<render::GlContext> ctx = render::createContext(render::Backend::Auto);
  ctx->makeCurrent();
  return *ctx;
}

/// A GPU frame with a fresh renderer and cache.
inline image::ImageF renderStore(std::shared_ptr<const store::BrickStore> s, const render::Scene& scene,
                                 render::FrameStats* stats = nullptr, size_t gpuBudget = size_t(256) << 20,
                                 size_t hostBudget = size_t(256) << 20, const render::FrameOptions& options = {}) {
  auto cache = std::make_shared<store::BrickCache>(std::move(s), hostBudget, 1);
  render::VolumeRenderer renderer(context(), cache, gpuBudget);
  return renderer.render(scene, stats, options);
}

/// Options that keep the levels the screen-space error chose whatever the budget, drawn batch by batch: what the
/// out-of-core suites compare with a frame drawn in one batch.
inline render::FrameOptions batched() {
  render::FrameOptions options;
  options.fitBudget = false;
  return options;
}

}  // namespace voxbrick::test
