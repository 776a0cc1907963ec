// A render thread's context and its renderers, one per dataset it has drawn.
#include "render/engine/RenderEngine.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>

#include "render/core/Interactive.h"
#include "render/core/RenderErrors.h"
#include "render/core/WorldFrame.h"
#include "render/gl/GlContext.h"
#include "render/gl/tets/TetRenderer.h"
#include "render/gl/volume/BrickAtlas.h"
#include "render/gl/volume/Residency.h"
#include "render/gl/volume/VolumeRenderer.h"
#include "render/volume/BrickStoreDataset.h"

namespace voxbrick::render {

struct RenderEngine::Impl {
  struct Entry {
    std::unique_ptr<FrameRenderer> renderer;
    uint64_t lastUse = 0;
  };

  std::unique_ptr<GlContext> context;
  RenderEngineOptions options;
  // Renderers hold GL objects, so they live and die with the context current. Keyed by the dataset's control block,
  // never its address: a dataset closed and another opened at the same address must not inherit a renderer.
  std::map<std::weak_ptr<const Dataset>, Entry, std::owner_less<>> renderers;
  uint64_t uses = 0;
  std::atomic<size_t> gpuBytes{0}, peakGpuBytes{0};
  std::atomic<uint64_t> released{0};
  RateGauge rates[2];                               // by DatasetKind, on the render thread
  std::atomic<double> recentRates[2] = {0.0, 0.0};  // their values, for any thread

  FrameRenderer& rendererFor(const std::shared_ptr<const Dataset>& dataset);
  /// The atlas bytes a new renderer of `dataset` would take under the whole budget.
  size_t wanted(const Dataset& dataset) const;
  void account();
};

size_t RenderEngine::Impl::wanted(const Dataset& dataset) const {
  // A mesh takes its resident size, at most the whole budget (a larger one is streamed).
  if (dataset.kind() == DatasetKind::TetMesh)
    return std::min(options.gpuBudgetBytes,
                    TetRenderer::bytesFor(static_cast<const TetMeshDataset&>(dataset).source()->constants().tetCount));
  return Residency::atlasBytes(*static_cast<const BrickStoreDataset&>(dataset).store(), options.gpuBudgetBytes,
                               options.atlasFormat, BrickAtlas::resolveUploads(*context, options.atlasUploads));
}

void RenderEngine::Impl::account() {
  size_t bytes = 0;
  for (const auto& [dataset, entry] : renderers) bytes += entry.renderer->gpuBytes();
  gpuBytes = bytes;
  if (bytes > peakGpuBytes) peakGpuBytes = bytes;
}

FrameRenderer& RenderEngine::Impl::rendererFor(const std::shared_ptr<const Dataset>& dataset) {
  // Renderers of datasets closed, or quarantined (they will draw nothing more), give their atlases back.
  if (std::erase_if(renderers, [](const auto& entry) {
        const auto d = entry.first.lock();
        return !d || d->quarantined();
      }) > 0)
    account();
  if (auto it = renderers.find(dataset); it != renderers.end()) {
    it->second.lastUse = ++uses;
    return *it->second.renderer;
  }
  // Room for the new atlas: release the renderers used least recently until the budget holds it whole.
  const size_t want = wanted(*dataset);
  account();
  while (!renderers.empty() && gpuBytes + want > options.gpuBudgetBytes) {
    auto oldest = std::min_element(renderers.begin(), renderers.end(),
                                   [](const auto& a, const auto& b) { return a.second.lastUse < b.second.lastUse; });
    renderers.erase(oldest);
    ++released;
    account();
  }
  std::unique_ptr<FrameRenderer> renderer;
  switch (dataset->kind()) {
    case DatasetKind::BrickStore:
      renderer = std::make_unique<VolumeRenderer>(*context, static_cast<const BrickStoreDataset&>(*dataset).cache(),
                                                  options.gpuBudgetBytes - gpuBytes, options.atlasFormat,
                                                  options.atlasUploads, options.atlasBricking);
      break;
    case DatasetKind::TetMesh:
      renderer = std::make_unique<TetRenderer>(*context, static_cast<const TetMeshDataset&>(*dataset).source(),
                                               options.gpuBudgetBytes - gpuBytes);
      break;
  }
  if (!renderer)
    throw RenderError("RenderEngine: no renderer for datasets of kind " +
                      std::string(datasetKindName(dataset->kind())));
  Entry& entry = renderers[dataset];
  entry.renderer = std::move(renderer);
  entry.lastUse = ++uses;
  account();
  return *entry.renderer;
}

RenderEngine::RenderEngine(const RenderEngineOptions& options) : mImpl(std::make_unique<Impl>()) {
  mImpl->options = options;
  mImpl->context = createContext(options.backend);
}

RenderEngine::~RenderEngine() {
  if (!mImpl->renderers.empty()) {
    mImpl->context->makeCurrent();
    mImpl->renderers.clear();
  }
}

void RenderEngine::makeCurrent() { mImpl->context->makeCurrent(); }
void RenderEngine::releaseCurrent() { mImpl->context->releaseCurrent(); }
std::string RenderEngine::describe() const { return mImpl->context->describe(); }
size_t RenderEngine::gpuBytes() const { return mImpl->gpuBytes; }
size_t RenderEngine::peakGpuBytes() const { return mImpl->peakGpuBytes; }
uint64_t RenderEngine::renderersReleased() const { return mImpl->released; }

image::ImageF RenderEngine::render(const std::shared_ptr<const Dataset>& dataset, const Scene& scene, FrameStats* stats,
                                   const FrameOptions& options) {
  if (!dataset) throw RenderInputError("RenderEngine::render: no dataset");
  if (mImpl->options.gridFrames && dataset->kind() == DatasetKind::BrickStore && !options.part)
    return mImpl->options.gridFrames(*this, dataset, scene, stats, options);
  std::optional<QualityChoice> choice;
  const Scene resolved = resolveQuality(*dataset, scene, &choice);
  FrameRenderer& renderer = mImpl->rendererFor(dataset);
  const size_t kind = dataset->kind() == DatasetKind::TetMesh ? 1 : 0;
  const double recent = mImpl->rates[kind].rate();
  FrameOptions frameOptions = options;
  if (frameOptions.cancelled && frameOptions.checkpointSamples <= 0)
    frameOptions.checkpointSamples = recent > 0 ? recent * kCheckpointMs : kFirstCheckpointSamples;
  FrameStats frameStats;
  image::ImageF image;
  if (resolved.interactive) {
    // Chosen by the estimate at the given (the session's) rate, else this engine's; timed as a whole, planning and
    // scaling up included.
    const auto start = std::chrono::steady_clock::now();
    const bool given = options.rateSamplesPerMs > 0;
    const InteractiveChoice chosen = chooseInteractive(resolved, given ? options.rateSamplesPerMs : recent,
                                                       given ? options.fixedMs : mImpl->rates[kind].fixedMs(),
                                                       [&](const Scene& s) { return renderer.estimateSamples(s); });
    image = renderer.render(interactiveScene(resolved, interactiveLadder()[size_t(chosen.rung)]), &frameStats,
                            frameOptions);
    image = scaleBilinear(image, resolved.width, resolved.height);
    frameStats.interactive = chosen.toJson();
    frameStats.interactive["actual_ms"] =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  } else {
    image = renderer.render(resolved, &frameStats, frameOptions);
  }
  mImpl->rates[kind].add(frameStats.samplesEstimated, frameStats.interactive.is_object()
                                                          ? frameStats.interactive["actual_ms"].get<double>()
                                                          : frameStats.msTotal);
  mImpl->recentRates[kind] = mImpl->rates[kind].rate();
  finishImage(dataset->worldFrame(), image);  // the renderers draw in the local frame
  if (choice) frameStats.quality = choice->toJson();
  if (stats) *stats = std::move(frameStats);
  return image;
}

BrickBudget RenderEngine::brickBudget(const std::shared_ptr<const Dataset>& dataset) const {
  if (!dataset || dataset->kind() != DatasetKind::BrickStore) return {};
  const auto it = mImpl->renderers.find(dataset);
  if (it == mImpl->renderers.end()) return {};
  return static_cast<const VolumeRenderer&>(*it->second.renderer).budget();
}

double RenderEngine::recentRate(DatasetKind kind) const {
  return mImpl->recentRates[kind == DatasetKind::TetMesh ? 1 : 0].load();
}

}  // namespace voxbrick::render
