// A dataset's stores, reference frames and measured settings.
#include "quality/DatasetRun.h"

#include <algorithm>

#include "brickstore/ingest/Sources.h"
#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/OpenAnyStore.h"
#include "quality/ReferenceCache.h"
#include "quality/Statistics.h"

namespace voxbrick::quality {
namespace fs = std::filesystem;

namespace {

/// The store of `d` with brick size `brick` in `work`, made by prep unless one from the same input is there; or the
/// one `d.store` names, as it is.
std::shared_ptr<const store::BrickStore> datasetStore(const Dataset& d, int brick, const fs::path& work) {
  const fs::path path = datasetStorePath(d, brick, work);
  if (!d.store.empty()) return store::openAnyStore(path);
  auto source = store::openSource(d.input, {});
  if (fs::exists(path / "store.json")) {
    auto existing = store::BrickStore::open(path);
    if (existing->meta().source == source->info().description && existing->brickSize() == brick) return existing;
  }
  store::PrepOptions options;
  options.brickSize = brick;
  options.writeVdb = false;
  options.overwrite = true;
  store::prepStore(*source, path, options);
  return store::BrickStore::open(path);
}

/// The per-view frame statistics of a setting, reduced to a point's medians.
struct ViewTimes {
  std::vector<double> ms, samples, fragments, terminated, passes;

  void add(const render::FrameStats& stats) {
    ms.push_back(stats.msTotal);
    samples.push_back(double(stats.samples));
    fragments.push_back(double(stats.fragments));
    terminated.push_back(double(stats.samplesTerminated));
    passes.push_back(double(stats.slabPasses));
  }

  void into(Point& p) const {
    p.msMedian = median(ms);
    p.msMin = *std::min_element(ms.begin(), ms.end());
    p.msMax = *std::max_element(ms.begin(), ms.end());
    p.samplesMedian = median(samples);
    p.fragmentsMedian = median(fragments);
    p.samplesTerminatedMedian = median(terminated);
    p.slabPassesMedian = median(passes);
  }
};

}  // namespace

render::Scene viewScene(const SweepSpec& spec, const Variant& variant, int view) {
  render::Scene scene;
  scene.width = scene.height = spec.size;
  scene.camera.azimuth = 360.0 * view / spec.views;
  scene.camera.elevation = spec.elevations.empty() ? 20 : spec.elevations[size_t(view) % spec.elevations.size()];
  scene.camera.distance = 2.2;
  scene.transferFunction = render::TransferFunction::load(variant.transferFunction);
  scene.transferFunctionName = variant.transferFunction;
  scene.shading = variant.shading;
  return scene;
}

DatasetRun::DatasetRun(const SweepSpec& spec, const Dataset& d, const fs::path& work, render::GlContext& context,
                       SweepResult& result, const std::function<void(const std::string&)>& log)
    : mSpec(spec), mDataset(d), mContext(context) {
  mStores[32] = datasetStore(d, 32, work);
  for (int b : spec.alternativeBricks) mStores[b] = datasetStore(d, b, work);
  mVariants = sweptVariants(spec, d);
  makeReferences(work, result, log);
}

void DatasetRun::makeReferences(const fs::path& work, SweepResult& result,
                                const std::function<void(const std::string&)>& log) {
  // Reference frames of every view of every variant, and the self-check of each default-TF variant.
  ReferenceCache references(work / "reference" / mDataset.name, mStores[32], kSweepBudget);
  for (const Variant& variant : mVariants) {
    std::vector<double> ms;
    mTruth.emplace_back();
    for (int v = 0; v < mSpec.views; ++v) {
      double rendered = -1;
      mTruth.back().push_back(references.get(viewScene(mSpec, variant, v), mSpec.referenceStep, &rendered));
      if (rendered >= 0) ms.push_back(rendered);
    }
    ReferenceReport report{mDataset.name, variant, median(ms)};
    if (variant.transferFunction == defaultVariant(mDataset).transferFunction) {
      const image::ImageError e = image::compareImages(
          mTruth.back()[0], references.get(viewScene(mSpec, variant, 0), mSpec.referenceStep / 2, nullptr));
      report.halvingPsnr = e.psnr;
      report.halvingMaxAbs = e.maxAbs;
    }
    result.references.push_back(report);
    log(mDataset.name + " reference, " + variant.label() + ": " + std::to_string(int(report.msPerView)) +
        " ms per view (0: cached)");
  }
}

size_t DatasetRun::variantIndex(const Variant& v) const {
  return size_t(std::find(mVariants.begin(), mVariants.end(), v) - mVariants.begin());
}

render::VolumeRenderer& DatasetRun::renderer(int brick) {
  std::unique_ptr<render::VolumeRenderer>& slot = mRenderers[brick];
  if (!slot)
    slot = std::make_unique<render::VolumeRenderer>(
        mContext, std::make_shared<store::BrickCache>(mStores.at(brick), kSweepBudget, 2), kSweepBudget);
  return *slot;
}

render::Scene DatasetRun::settingScene(const Setting& setting, const Variant& variant, int view) const {
  render::Scene scene = viewScene(mSpec, variant, view);
  scene.step = setting.step;
  scene.skipEmpty = setting.skip;
  scene.slicer = setting.slicer;
  scene.slab = setting.slab;
  scene.raycast = setting.raycast;
  scene.ert = setting.ert;
  scene.preIntegration = setting.preIntegration;
  scene.subBlock = setting.subBlock;
  scene.lod = setting.lod;
  return scene;
}

Point DatasetRun::measure(const Setting& setting, size_t variantIndex) {
  const Variant& variant = mVariants[variantIndex];
  render::VolumeRenderer& r = renderer(setting.brick);
  // Warm-up: pages what this setting draws, builds its programs.
  if (mSpec.frames8)
    r.render8(settingScene(setting, variant, 0));
  else
    r.render(settingScene(setting, variant, 0));
  Point p{mDataset.name, variant, setting};
  ViewTimes times;
  ErrorTally errors;
  for (int v = 0; v < mSpec.views; ++v) {
    render::FrameStats stats;
    const render::Scene scene = settingScene(setting, variant, v);
    if (mSpec.frames8) r.render8(scene, &stats);
    const image::ImageF image = mSpec.frames8 ? r.render(scene) : r.render(scene, &stats);
    times.add(stats);
    errors.add(image::compareImages(image, mTruth[variantIndex][size_t(v)]));
  }
  times.into(p);
  p.psnrMin = errors.psnrMin;
  p.maxAbs = errors.maxAbs;
  p.rmsePooled = errors.rmsePooled();
  p.psnrPooled = errors.psnrPooled();
  return p;
}

}  // namespace voxbrick::quality
