// What a render thread holds: its own GL context and, per dataset it has drawn, the renderer its kind's driver made
// (DatasetDriver.h). The local FrameSource; this header shows no GL.
#pragma once

#include <memory>
#include <span>
#include <string>

#include "image/Image.h"
#include "render/core/Dataset.h"
#include "render/core/FrameRenderer.h"
#include "render/core/FrameStats.h"
#include "render/core/Scene.h"
#include "render/engine/EngineOptions.h"
#include "render/engine/FrameSource.h"

namespace voxbrick::render {

class RenderEngine final : public FrameSource {
 public:
  /// Makes a GL context with `options.backend` (see createContext) and leaves it current on the calling thread.
  /// Throws RenderError listing what was tried.
  explicit RenderEngine(const RenderEngineOptions& options);
  ~RenderEngine() override;
  RenderEngine(const RenderEngine&) = delete;
  RenderEngine& operator=(const RenderEngine&) = delete;

  /// Binds the context to the calling thread; one thread at a time.
  void makeCurrent() override;
  /// Unbinds it, so that another thread may take the engine.
  void releaseCurrent() override;
  /// How the context was made and what runs it.
  std::string describe() const override;

  /// One frame of `dataset` (the context must be current): the renderer for the dataset's kind, made on first use
  /// and kept while the dataset lives. An interactive scene (Scene::interactive) is drawn within its time budget:
  /// chooseInteractive (render/core/Interactive.h) picks a reduced drawing by the renderer's sample estimate and
  /// options.rateSamplesPerMs (else recentRate()), the drawing is scaled up to the scene's size, and
  /// stats->interactive says what was chosen. A frame that may be cancelled has its checkpoint intervals sized to
  /// kCheckpointMs of work at recentRate() (FrameOptions::checkpointSamples, unless given). Every frame drawn feeds
  /// recentRate(). Throws RenderInputError for a scene the dataset cannot be drawn with and RenderError for GL
  /// failures.
  image::ImageF render(const std::shared_ptr<const Dataset>& dataset, const Scene& scene, FrameStats* stats = nullptr,
                       const FrameOptions& options = {}) override;
  /// The same frame as 8-bit RGBA, finished on the GPU by the renderer (FrameRenderer::render8) when the frame is
  /// drawn at the scene's size; an interactive frame, drawn smaller and scaled up in float, is converted after.
  image::Image8 render8(const std::shared_ptr<const Dataset>& dataset, const Scene& scene, FrameStats* stats = nullptr,
                        const FrameOptions& options = {}) override;
  /// Each scene's frame as render8 gives it, handed to `deliver` in order as soon as it is read back: a grid's next
  /// frame is planned while the GPU draws the last (FrameRenderer::renderSequence8). Scenes with a quality target
  /// or drawn interactively, and cancellable frames, are drawn one by one through render8.
  void renderSequence8(const std::shared_ptr<const Dataset>& dataset, std::span<const Scene> scenes,
                       const FrameOptions& options, const FrameDelivery& deliver);
  /// Pages ahead through the driver of the dataset's kind (DatasetDriver::prefetch), fitted to what this engine's
  /// renderer of it holds. The context must be current. Never throws.
  void prefetch(const std::shared_ptr<const Dataset>& dataset, const Scene& scene) override;

  /// The estimated samples per ms (FrameStats::samplesEstimated over msTotal) of the frames of datasets of
  /// `dataset`'s kind this engine drew lately (RateGauge); 0 before the first. Any thread may ask.
  double recentRate(const Dataset& dataset) const;
  /// The work between two cancellation checkpoints, in ms at the recent rate.
  static constexpr double kCheckpointMs = 30;
  /// The checkpoint interval in samples before a frame of that kind has been timed.
  static constexpr double kFirstCheckpointSamples = 1e6;

  /// GPU memory its renderers hold now (their atlases); never above options.gpuBudgetBytes. Any thread may ask.
  size_t gpuBytes() const override;
  /// The most gpuBytes() has been.
  size_t peakGpuBytes() const override;
  /// Renderers released to stay within the budget so far.
  uint64_t renderersReleased() const override;

 private:
  /// render and render8: the frame as floats, or with `eightBit` as 8 bits in `*image8` where the renderer draws it
  /// at the scene's size (an interactive frame is returned as floats, to be converted).
  image::ImageF renderAny(const std::shared_ptr<const Dataset>& dataset, const Scene& scene, FrameStats* stats,
                          const FrameOptions& options, image::Image8* image8);

  struct Impl;
  std::unique_ptr<Impl> mImpl;
};

}  // namespace voxbrick::render
