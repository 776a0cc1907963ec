// A render thread's context and its renderers, one per dataset it has drawn.
#include "render/engine/RenderEngine.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <mutex>

#include "render/core/Interactive.h"
#include "render/core/RenderErrors.h"
#include "render/core/WorldFrame.h"
#include "render/engine/DatasetDriver.h"
#include "render/gl/GlContext.h"
#include "render/gl/GlObjects.h"

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
  std::map<std::string, RateGauge, std::less<>> rates;  // by kind, on the render thread
  mutable std::mutex recentMutex;
  std::map<std::string, double, std::less<>> recentRates;  // their values, for any thread

  /// The dataset's renderer on this context, made (and the least recently used ones released for its atlas) when it
  /// has none; `madeMs`, if given, gets the milliseconds making it took (0 when it was there).
  FrameRenderer& rendererFor(const std::shared_ptr<const Dataset>& dataset, const DatasetDriver& driver,
                             double* madeMs = nullptr);
  RendererSetup setup(size_t left) { return {*context, options, left}; }
  RateGauge& rateOf(std::string_view kind) {
    auto it = rates.find(kind);
    if (it == rates.end()) it = rates.emplace(std::string(kind), RateGauge{}).first;
    return it->second;
  }
  void account();
};

void RenderEngine::Impl::account() {
  size_t bytes = 0;
  for (const auto& [dataset, entry] : renderers) bytes += entry.renderer->gpuBytes();
  gpuBytes = bytes;
  if (bytes > peakGpuBytes) peakGpuBytes = bytes;
}

FrameRenderer& RenderEngine::Impl::rendererFor(const std::shared_ptr<const Dataset>& dataset,
                                               const DatasetDriver& driver, double* madeMs) {
  if (madeMs) *madeMs = 0;
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
  const auto start = std::chrono::steady_clock::now();
  // Room for the new atlas: release the renderers used least recently until the budget holds it whole.
  const size_t want = driver.gpuBytesWanted(*dataset, setup(options.gpuBudgetBytes));
  account();
  while (!renderers.empty() && gpuBytes + want > options.gpuBudgetBytes) {
    auto oldest = std::min_element(renderers.begin(), renderers.end(),
                                   [](const auto& a, const auto& b) { return a.second.lastUse < b.second.lastUse; });
    renderers.erase(oldest);
    ++released;
    account();
  }
  std::unique_ptr<FrameRenderer> renderer = driver.makeRenderer(*dataset, setup(options.gpuBudgetBytes - gpuBytes));
  if (!renderer)
    throw RenderError("RenderEngine: the driver of kind " + std::string(dataset->kind()) + " made no renderer");
  Entry& entry = renderers[dataset];
  entry.renderer = std::move(renderer);
  entry.lastUse = ++uses;
  account();
  if (madeMs) *madeMs = msSince(start);
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
  return renderAny(dataset, scene, stats, options, nullptr);
}

image::Image8 RenderEngine::render8(const std::shared_ptr<const Dataset>& dataset, const Scene& scene,
                                    FrameStats* stats, const FrameOptions& options) {
  image::Image8 image8;
  const image::ImageF image = renderAny(dataset, scene, stats, options, &image8);
  return image8.rgba.empty() ? image::toImage8(image) : std::move(image8);
}

image::ImageF RenderEngine::renderAny(const std::shared_ptr<const Dataset>& dataset, const Scene& scene,
                                      FrameStats* stats, const FrameOptions& options, image::Image8* image8) {
  if (!dataset) throw RenderInputError("RenderEngine::render: no dataset");
  const DatasetDriver& driver = driverFor(*dataset);
  std::optional<QualityChoice> choice;
  const Scene resolved = resolveQuality(*dataset, scene, &choice);
  // One-time work on this context: the renderer made now (its programs built within it), and programs built while
  // drawing (a variant drawn the first time).
  double madeMs = 0;
  FrameRenderer& renderer = mImpl->rendererFor(dataset, driver, &madeMs);
  const double builtBefore = programBuildMsOnThisThread();
  RateGauge& rate = mImpl->rateOf(dataset->kind());
  const double recent = rate.rate();
  FrameOptions frameOptions = options;
  if (frameOptions.cancelled && frameOptions.checkpointSamples <= 0)
    frameOptions.checkpointSamples = recent > 0 ? recent * kCheckpointMs : kFirstCheckpointSamples;
  FrameStats frameStats;
  image::ImageF image;
  if (resolved.interactive) {
    // Chosen by the estimate at the given (the session's) rate, else this engine's; timed as a whole, planning and
    // scaling up included.
    const auto start = std::chrono::steady_clock::now();
    const double outputScale = options.outputScale;
    if (!(outputScale > 0 && outputScale <= 1))
      throw RenderInputError("RenderEngine::render: outputScale " + std::to_string(outputScale) +
                             " is not in (0, 1]");
    const bool given = options.rateSamplesPerMs > 0;
    const InteractiveChoice chosen = chooseInteractive(
        resolved, given ? options.rateSamplesPerMs : recent, given ? options.fixedMs : rate.fixedMs(),
        [&](const Scene& s) { return renderer.estimateSamples(s); }, outputScale);
    const Scene drawn = interactiveScene(resolved, interactiveLadder()[size_t(chosen.rung)], outputScale);
    const int width = scaledSide(resolved.width, outputScale), height = scaledSide(resolved.height, outputScale);
    // Bytes are drawn as bytes and scaled up as bytes (image::scaleImage): within one level of the float frame
    // scaled up and rounded, for a third of the memory traffic of a float frame of the scene's size.
    if (image8) {
      *image8 = renderer.render8(drawn, &frameStats, frameOptions);
      if (!options.keepReducedSize && (image8->width != width || image8->height != height))
        *image8 = image::scaleImage(*image8, width, height);
    } else {
      image = renderer.render(drawn, &frameStats, frameOptions);
      if (!options.keepReducedSize) image = scaleBilinear(image, width, height);
    }
    frameStats.interactive = chosen.toJson();
    frameStats.interactive["actual_ms"] = msSince(start);
  } else if (image8) {
    *image8 = renderer.render8(resolved, &frameStats, frameOptions);
  } else {
    image = renderer.render(resolved, &frameStats, frameOptions);
  }
  rate.add(frameStats.samplesEstimated, frameStats.interactive.is_object()
                                            ? frameStats.interactive["actual_ms"].get<double>()
                                            : frameStats.msTotal);
  {
    std::lock_guard lock(mImpl->recentMutex);
    mImpl->recentRates[std::string(dataset->kind())] = rate.rate();
  }
  // The renderers draw in the local frame.
  if (image8 && !image8->rgba.empty())
    finishImage(dataset->worldFrame(), *image8);
  else
    finishImage(dataset->worldFrame(), image);
  if (choice) frameStats.quality = choice->toJson();
  frameStats.msWarmup = madeMs + (programBuildMsOnThisThread() - builtBefore);
  if (stats) *stats = std::move(frameStats);
  return image;
}

void RenderEngine::renderSequence8(const std::shared_ptr<const Dataset>& dataset, std::span<const Scene> scenes,
                                   const FrameOptions& options, const FrameDelivery& deliver) {
  if (!dataset) throw RenderInputError("RenderEngine::renderSequence8: no dataset");
  const bool oneByOne = options.cancelled || std::any_of(scenes.begin(), scenes.end(), [](const Scene& s) {
                          return s.interactive || s.quality.has_value();
                        });
  if (oneByOne) {
    for (size_t i = 0; i < scenes.size(); ++i) {
      FrameStats stats;
      image::Image8 image = render8(dataset, scenes[i], &stats, options);
      deliver(i, std::move(image), stats);
    }
    return;
  }
  FrameRenderer& renderer = mImpl->rendererFor(dataset, driverFor(*dataset));
  RateGauge& rate = mImpl->rateOf(dataset->kind());
  renderer.renderSequence8(scenes, options, [&](size_t i, image::Image8&& image, const FrameStats& stats) {
    rate.add(stats.samplesEstimated, stats.msTotal);
    {
      std::lock_guard lock(mImpl->recentMutex);
      mImpl->recentRates[std::string(dataset->kind())] = rate.rate();
    }
    finishImage(dataset->worldFrame(), image);  // the renderers draw in the local frame
    deliver(i, std::move(image), stats);
  });
}

void RenderEngine::prefetch(const std::shared_ptr<const Dataset>& dataset, const Scene& scene) {
  if (!dataset) return;
  try {
    const DatasetDriver& driver = driverFor(*dataset);
    const auto it = mImpl->renderers.find(dataset);
    driver.prefetch(*dataset, scene, it == mImpl->renderers.end() ? nullptr : it->second.renderer.get());
  } catch (...) {
    // Advisory: a kind without a driver, or a camera that cannot be planned, pages nothing ahead.
  }
}

double RenderEngine::recentRate(const Dataset& dataset) const {
  std::lock_guard lock(mImpl->recentMutex);
  const auto it = mImpl->recentRates.find(dataset.kind());
  return it == mImpl->recentRates.end() ? 0.0 : it->second;
}

}  // namespace voxbrick::render
