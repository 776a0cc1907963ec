// A render thread's context and its renderers, one per dataset it has drawn.
#include "render/RenderEngine.h"

#include <map>

#include "render/GlContext.h"
#include "render/RenderErrors.h"
#include "render/VolumeRenderer.h"

namespace voxbrick::render {

struct RenderEngine::Impl {
  std::unique_ptr<GlContext> context;
  RenderEngineOptions options;
  // Renderers hold GL objects, so they live and die with the context current. Keyed by the dataset's control block,
  // never its address: a dataset closed and another opened at the same address must not inherit a renderer.
  std::map<std::weak_ptr<const Dataset>, std::unique_ptr<FrameRenderer>, std::owner_less<>> renderers;

  FrameRenderer& rendererFor(const std::shared_ptr<const Dataset>& dataset);
};

FrameRenderer& RenderEngine::Impl::rendererFor(const std::shared_ptr<const Dataset>& dataset) {
  std::erase_if(renderers, [](const auto& entry) { return entry.first.expired(); });
  auto& renderer = renderers[dataset];
  if (!renderer) {
    switch (dataset->kind()) {
      case DatasetKind::BrickStore:
        renderer = std::make_unique<VolumeRenderer>(
            *context, static_cast<const BrickStoreDataset&>(*dataset).cache(), options.gpuBudgetBytes,
            options.atlasFormat);
        break;
    }
    if (!renderer) throw RenderError("RenderEngine: no renderer for datasets of kind " +
                                     std::string(datasetKindName(dataset->kind())));
  }
  return *renderer;
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

image::ImageF RenderEngine::render(const std::shared_ptr<const Dataset>& dataset, const Scene& scene, FrameStats* stats) {
  if (!dataset) throw RenderInputError("RenderEngine::render: no dataset");
  return mImpl->rendererFor(dataset).render(scene, stats);
}

}  // namespace voxbrick::render
