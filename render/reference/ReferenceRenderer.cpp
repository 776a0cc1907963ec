// The reference renderer's frame loop: one ray per pixel centre (ReferenceFrame), integrated along it
// (ReferenceRayIntegrator) from the grid's bricks (ReferenceGridSampler) or the synthetic field itself, in double.
#include "render/reference/ReferenceRenderer.h"

#include <atomic>
#include <chrono>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "render/core/RenderErrors.h"
#include "render/core/WorldFrame.h"
#include "render/reference/ReferenceAnalyticSampler.h"
#include "render/reference/ReferenceBricks.h"
#include "render/reference/ReferenceFrame.h"
#include "render/reference/ReferenceGridSampler.h"
#include "render/reference/ReferenceRayIntegrator.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;
using reference::AnalyticSampler;
using reference::Frame;
using reference::GridSampler;
using reference::Ray;
using reference::RayIntegrator;

}  // namespace

ReferenceRenderer::ReferenceRenderer(std::shared_ptr<store::BrickCache> cache)
    : mCache(std::move(cache)), mBricks(std::make_unique<ReferenceBricks>(mCache)) {}

ReferenceRenderer::~ReferenceRenderer() = default;

image::ImageF ReferenceRenderer::render(const Scene& scene, const ReferenceOptions& options, ReferenceStats* statsOut) {
  const auto start = Clock::now();
  scene.validate();
  if (!(options.step >= 1e-4 && options.step <= 64))
    throw RenderInputError("ReferenceRenderer: step " + numberText(options.step) + " is outside [1e-4, 64] voxels");
  const store::BrickStore& store = *mCache->store();
  const store::StoreMeta& meta = store.meta();

  if (!options.brickLevels.empty()) {
    if (options.analytic) throw RenderInputError("ReferenceRenderer: per-brick levels sample the store, not a field");
    if (options.brickLevels.size() != size_t(meta.levels.at(0).bricksTotal()))
      throw RenderInputError("ReferenceRenderer: " + std::to_string(options.brickLevels.size()) + " brick levels for " +
                             std::to_string(meta.levels.at(0).bricksTotal()) + " bricks");
    for (uint8_t l : options.brickLevels)
      if (int(l) >= store.levelCount())
        throw RenderInputError("ReferenceRenderer: brick level " + std::to_string(int(l)) + " beyond the store's " +
                               std::to_string(store.levelCount()) + " levels");
  }
  Frame f = reference::makeFrame(scene, options, meta);
  if (!options.analytic && scene.skipEmpty) reference::markTransparentBricks(f, store, options.brickLevels);

  image::ImageF image{scene.width, scene.height, std::vector<float>(size_t(scene.width) * size_t(scene.height) * 4)};
  std::atomic<int64_t> rays{0}, samples{0}, skipped{0};
  auto renderRows = [&](const auto& sampler) {
    tbb::parallel_for(tbb::blocked_range<int>(0, scene.height), [&](const tbb::blocked_range<int>& rows) {
      int64_t rowRays = 0, rowSamples = 0, rowSkipped = 0;
      for (int y = rows.begin(); y != rows.end(); ++y)
        for (int x = 0; x < scene.width; ++x) {
          const Ray ray = reference::pixelRay(f, x, y, scene.width, scene.height);
          rowRays += ray.t1 > ray.t0 ? 1 : 0;
          const glm::dvec4 c = RayIntegrator(f, sampler, ray, rowSamples, rowSkipped).run();
          float* out = image.pixel(x, y);
          for (int ch = 0; ch < 4; ++ch) out[ch] = float(c[ch]);
        }
      rays += rowRays;
      samples += rowSamples;
      skipped += rowSkipped;
    });
  };
  if (options.analytic) {
    renderRows(AnalyticSampler(*options.analytic, meta));
  } else {
    store::dispatchType(
        meta.type, [&](auto zero) { renderRows(GridSampler<decltype(zero)>(*mBricks, meta, options.brickLevels)); });
  }

  if (statsOut) {
    statsOut->rays = rays;
    statsOut->samples = samples;
    statsOut->bricksSkipped = skipped;
    statsOut->ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  }
  finishImage(WorldFrame::of(meta.orientation, meta.dims, meta.spacing), image);
  return image;
}

store::SyntheticField analyticFieldFor(const store::StoreMeta& meta, const std::string& spec) {
  const std::string name = spec.substr(0, spec.find(','));
  // prep records a synthetic source as "synthetic NAME NXxNYxNZ".
  const std::string recorded = "synthetic " + name + " ";
  if (meta.source.rfind(recorded, 0) != 0)
    throw RenderInputError("analytic field '" + spec + "': the store was made from '" + meta.source +
                           "', not from synthetic:" + name);
  const bool hasDims = spec.find(",n=") != std::string::npos || spec.find(",nx=") != std::string::npos ||
                       spec.find(",ny=") != std::string::npos || spec.find(",nz=") != std::string::npos;
  const std::string full = hasDims ? spec
                                   : spec + ",nx=" + std::to_string(meta.dims.x) +
                                         ",ny=" + std::to_string(meta.dims.y) + ",nz=" + std::to_string(meta.dims.z);
  store::SyntheticField field = store::SyntheticField::parse(full);
  if (!(field.dims() == meta.dims))
    throw RenderInputError("analytic field '" + spec + "': dims " + std::to_string(field.dims().x) + "x" +
                           std::to_string(field.dims().y) + "x" + std::to_string(field.dims().z) +
                           " differ from the store's");
  field.setSpacing(meta.spacing);
  return field;
}

}  // namespace voxbrick::render
