// What draws a server's frames, one per render thread: the local engine (RenderEngine), sort-last rendering across
// MPI ranks (distributed/SortLastSource.h, which wraps an engine), or nothing at all (NullFrameSource, so that the
// scheduler and everything above it run without GL). The server's scheduler sees only this. GL-free.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "image/Image.h"
#include "render/core/Dataset.h"
#include "render/core/FrameRenderer.h"
#include "render/core/FrameStats.h"
#include "render/core/Scene.h"

namespace voxbrick::render {

class FrameSource {
 public:
  virtual ~FrameSource() = default;

  /// Binds what it draws with to the calling thread (a render thread, before its first frame); one thread at a time.
  virtual void makeCurrent() {}
  /// Unbinds it, so that another thread may take it (or destroy it).
  virtual void releaseCurrent() {}
  /// What draws: the context and what runs it, or the ranks.
  virtual std::string describe() const = 0;

  /// One frame of `dataset` (see RenderEngine::render). Throws RenderInputError for a scene the dataset cannot be
  /// drawn with, RenderLimitError above options.maxSamples, FrameCancelled when options.cancelled says so, and
  /// RenderError for failures of what draws.
  virtual image::ImageF render(const std::shared_ptr<const Dataset>& dataset, const Scene& scene,
                               FrameStats* stats = nullptr, const FrameOptions& options = {}) = 0;
  /// The same frame as 8-bit RGBA, the bytes image::toImage8(render(...)) gives (what a reply carries). Default:
  /// render and convert; the local engine finishes on the GPU where its renderer can (FrameRenderer::render8).
  virtual image::Image8 render8(const std::shared_ptr<const Dataset>& dataset, const Scene& scene,
                                FrameStats* stats = nullptr, const FrameOptions& options = {}) {
    return image::toImage8(render(dataset, scene, stats, options));
  }
  /// Pages ahead for `scene`, a frame of `dataset` likely to come next (a drag's next camera). Advisory; never
  /// throws. Default: nothing.
  virtual void prefetch(const std::shared_ptr<const Dataset>& dataset, const Scene& scene) {
    (void)dataset, (void)scene;
  }
  /// Checks that the dataset named `name` may be served by this source, when the server opens it (sort-last: every
  /// rank opens it and they agree). Throws RenderInputError naming what is wrong. Called on any thread, also
  /// while a frame is drawn. Default: nothing to check.
  virtual void checkDataset(const std::string& name) { (void)name; }

  /// GPU memory it holds now, its peak, and the renderers it released to stay within its budget.
  virtual size_t gpuBytes() const { return 0; }
  virtual size_t peakGpuBytes() const { return 0; }
  virtual uint64_t renderersReleased() const { return 0; }
};

/// The checks of a source that draws nothing itself (NullFrameSource, ReplayFrameSource) before a frame: throws
/// RenderInputError without a dataset, RenderLimitError when the scene's width times height (its "estimate") is above
/// options.maxSamples. Returns that estimate.
double checkedPixelSamples(const std::shared_ptr<const Dataset>& dataset, const Scene& scene,
                           const FrameOptions& options);

/// Spends the time until `end`, in steps of at most 1 ms, asking options.cancelled between them (FrameCancelled when
/// it says so): the drawing time of a source that draws nothing itself (NullFrameSource, ReplayFrameSource).
void spendDrawingTime(std::chrono::steady_clock::time_point end, const FrameOptions& options);

}  // namespace voxbrick::render
