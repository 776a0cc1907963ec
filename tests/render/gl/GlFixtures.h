// Fixtures of the GL rendering suites: one GL context per test binary, frames from the GPU renderer.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "render/RenderFixtures.h"
#include "render/gl/FilterProbe.h"
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

/// The context's filter precision (render/gl/FilterProbe.h), measured once and printed.
inline const render::FilterPrecision& filterPrecision() {
  static const render::FilterPrecision precision = [] {
    const render::FilterPrecision p = render::measureFilterPrecision(context());
    std::printf("[ info ] %s: linear filter weight step %.3g (%d sub-texel bits; 0: float), worst weight error %.3g\n",
                context().describe().c_str(), p.weightStep, p.subTexelBits(), p.maxWeightError);
    return p;
  }();
  return precision;
}

/// The largest difference between neighbouring voxels (along any axis, in any brick of any level, borders
/// included) of `s`, in its raw values. Reads every brick: use largestVoxelStep, which keeps it per store.
inline double largestRawVoxelStep(const store::BrickStore& s) {
  const size_t e = size_t(s.brickEdge());
  std::vector<float> values(e * e * e);
  std::vector<unsigned char> raw(s.brickBytes());
  double step = 0;
  for (int level = 0; level < s.levelCount(); ++level) {
    const store::Vec3i b = s.level(level).bricks;
    for (int64_t k = 0; k < b.z; ++k)
      for (int64_t j = 0; j < b.y; ++j)
        for (int64_t i = 0; i < b.x; ++i) {
          const store::BrickKey key{uint32_t(level), uint32_t(i), uint32_t(j), uint32_t(k)};
          if (!s.isStored(key)) continue;
          s.readBrick(key, raw.data());
          store::dispatchType(s.type(), [&](auto tag) {
            const auto* v = reinterpret_cast<const decltype(tag)*>(raw.data());
            for (size_t n = 0; n < values.size(); ++n) values[n] = float(v[n]);
          });
          for (size_t z = 0; z < e; ++z)
            for (size_t y = 0; y < e; ++y)
              for (size_t x = 0; x < e; ++x) {
                const float v = values[(z * e + y) * e + x];
                if (x + 1 < e) step = std::max(step, double(std::abs(values[(z * e + y) * e + x + 1] - v)));
                if (y + 1 < e) step = std::max(step, double(std::abs(values[(z * e + y + 1) * e + x] - v)));
                if (z + 1 < e) step = std::max(step, double(std::abs(values[((z + 1) * e + y) * e + x] - v)));
              }
        }
  }
  return step;
}

/// largestRawVoxelStep of `s` in units of `scene`'s value window (the store's value range by default). The raw step
/// is computed once per store (its object, path, size and value range) for the whole binary.
inline double largestVoxelStep(const store::BrickStore& s, const render::Scene& scene) {
  static std::map<std::string, double> steps;
  const store::StoreMeta& m = s.meta();
  std::ostringstream id;
  id.precision(17);
  id << static_cast<const void*>(&s) << ' ' << m.dims.x << ' ' << m.dims.y << ' ' << m.dims.z << ' ' << m.valueMin
     << ' ' << m.valueMax << ' ' << s.path().string();
  auto it = steps.find(id.str());
  if (it == steps.end()) it = steps.emplace(id.str(), largestRawVoxelStep(s)).first;
  const double lo = scene.window ? (*scene.window)[0] : m.valueMin;
  const double hi = scene.window ? (*scene.window)[1] : m.valueMax;
  return hi > lo ? it->second / (hi - lo) : 0.0;
}

/// How far a classified sample can move when its fetch moves by `valueChange` of the window: the largest change of
/// the transfer function's premultiplied RGBA between window positions that far apart.
inline double transferFunctionChange(const render::TransferFunction& tf, double valueChange) {
  auto premultiplied = [&](double x) {
    const glm::dvec4 c = tf.evaluate(std::clamp(x, 0.0, 1.0));
    return glm::dvec4(glm::dvec3(c) * c.a, c.a);
  };
  double change = 0;
  for (int i = 0; i <= 4096; ++i) {
    const double x = i / 4096.0;
    change = std::max(change, maxDifference(premultiplied(x), premultiplied(x + valueChange)));
  }
  return change;
}

/// How far two drawings of `scene` from `s` that sample the same points by differently rounded coordinates
/// (slabs or the ray caster against slicing, another atlas slot or bricking, another slicer, sub-blocks) may differ
/// beyond what a float filter allows, on a filter of weight step q (filterPrecision; 0 where it filters in float,
/// as llvmpipe does, and then there is no slack). A fetch's three weights can each land one step apart where the
/// coordinates straddle a step, moving the value by up to 3 q S (S: largestVoxelStep) and a classified sample by up
/// to D = transferFunctionChange(3 q S). Straddles are rare, but a ray can meet several: kStraddlesPerRay of them.
inline double filterSlack(const store::BrickStore& s, const render::Scene& scene) {
  const double q = filterPrecision().weightStep;
  if (q == 0) return 0;
  // The H200's worst seen over these suites was 4.7 D (Marschner-Lobb through "hot"): 8 leaves room for other views.
  constexpr double kStraddlesPerRay = 8;
  return kStraddlesPerRay * transferFunctionChange(scene.transferFunction, 3 * q * largestVoxelStep(s, scene));
}

/// Expects two drawings of `scene` from `s` that should give the same image to agree: max |diff| <= maxAbs where the
/// filter is float (llvmpipe: exactly the check it always was). Where it is fixed-point, max |diff| <= maxAbs +
/// filterSlack, and, since with a steep transfer function that slack can be large while the pixels that differ stay
/// isolated, also rmse <= kFixedPointRmse (60 dB; the H200 kept them at 65 dB or better): no systematic drift.
inline void expectSameDrawing(const image::ImageF& a, const image::ImageF& b, double maxAbs, const store::BrickStore& s,
                              const render::Scene& scene, const std::string& what) {
  const double slack = filterSlack(s, scene);
  if (slack > 0) {
    constexpr double kFixedPointRmse = 1e-3;
    const image::ImageError e = image::compareImages(a, b);
    EXPECT_LE(e.rmse, kFixedPointRmse) << what << ": max |diff| " << e.maxAbs << " (bound " << maxAbs + slack
                                       << " with the filter's slack)";
    std::printf("[ info ] %s: max |diff| %.3g, rmse %.3g, bound %.3g + filter slack %.3g\n", what.c_str(), e.maxAbs,
                e.rmse, maxAbs, slack);
  }
  expectClose(a, b, maxAbs + slack, what);
}

/// Waits until the cache's workers have nothing queued or running (at most 60 s; fails the test if they do not).
inline void waitForPaging(const store::BrickCache& cache) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    const store::CacheStats st = cache.stats();
    if (st.prefetchQueued == 0 && st.inFlight == 0) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  FAIL() << "the cache's workers did not finish";
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
