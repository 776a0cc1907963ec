// Fixtures of the GL rendering suites: one GL context per test binary, frames from the GPU renderer.
#pragma once

#include <memory>
#include <string>

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

/// Whether `backend` exists in this process: false only for OSMesa where libOSMesa is the GPU kit's stand-in
/// (render::osMesaStandIn), which has no backend behind it. Suites that loop over backends leave such a backend out
/// and end with skipMissingBackends, so that a kit run reports the case as skipped with the reason, not failed.
inline bool backendExists(render::Backend backend) {
  return backend != render::Backend::OsMesa || render::osMesaStandIn().empty();
}

/// Marks the running test skipped, naming why, if a backend it loops over does not exist here (backendExists). Call
/// it at the end of the test: its other backends' checks have run by then, and a failure among them still fails it.
inline void skipMissingBackends() {
  if (const std::string standIn = render::osMesaStandIn(); !standIn.empty())
    GTEST_SKIP() << "the OSMesa cases did not run: libOSMesa here is " << standIn << "; the EGL cases ran";
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
