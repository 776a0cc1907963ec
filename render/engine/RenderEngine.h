// What a render thread holds: its own GL context and, per dataset it has drawn, the renderer of that dataset's kind.
// This header is the renderer's whole interface for the server: it shows no GL.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "image/Image.h"
#include "render/core/Backend.h"
#include "render/core/Dataset.h"
#include "render/core/FrameRenderer.h"
#include "render/core/FrameStats.h"
#include "render/core/Scene.h"
#include "render/volume/AtlasFormat.h"
#include "render/volume/WorkingSet.h"

namespace voxbrick::render {

class RenderEngine;

/// Draws a frame of a grid dataset some other way, given the engine that was asked for it: sort-last rendering
/// across MPI ranks (distributed/) draws this rank's part with the same engine (FrameOptions::part) and composites.
using GridFrames = std::function<image::ImageF(RenderEngine&, const std::shared_ptr<const Dataset>&, const Scene&,
                                               FrameStats*, const FrameOptions&)>;

/// How a RenderEngine makes its context and its renderers.
struct RenderEngineOptions {
  Backend backend = Backend::Auto;
  /// The atlases of all its renderers together (one per dataset drawn): a renderer not used for the longest is
  /// released to make room for another dataset's atlas.
  size_t gpuBudgetBytes = size_t(1) << 30;
  AtlasFormat atlasFormat = AtlasFormat::Float;         ///< how atlases store samples
  AtlasUploads atlasUploads = AtlasUploads::Auto;       ///< how bricks reach the atlases
  AtlasBricking atlasBricking = AtlasBricking::Single;  ///< how bricks lie in the atlases
  /// Set: render() hands every frame of a brick store without FrameOptions::part to it (which may call render()
  /// again with a part). Empty: the engine draws every frame itself.
  GridFrames gridFrames = {};
};

class RenderEngine {
 public:
  /// Makes a GL context with `options.backend` (see createContext) and leaves it current on the calling thread.
  /// Throws RenderError listing what was tried.
  explicit RenderEngine(const RenderEngineOptions& options);
  ~RenderEngine();
  RenderEngine(const RenderEngine&) = delete;
  RenderEngine& operator=(const RenderEngine&) = delete;

  /// Binds the context to the calling thread; one thread at a time.
  void makeCurrent();
  /// Unbinds it, so that another thread may take the engine.
  void releaseCurrent();
  /// How the context was made and what runs it.
  std::string describe() const;

  /// One frame of `dataset` (the context must be current): the renderer for the dataset's kind, made on first use
  /// and kept while the dataset lives. An interactive scene (Scene::interactive) is drawn within its time budget:
  /// chooseInteractive (render/core/Interactive.h) picks a reduced drawing by the renderer's sample estimate and
  /// options.rateSamplesPerMs (else recentRate()), the drawing is scaled up to the scene's size, and
  /// stats->interactive says what was chosen. A frame that may be cancelled has its checkpoint intervals sized to
  /// kCheckpointMs of work at recentRate() (FrameOptions::checkpointSamples, unless given). Every frame drawn feeds
  /// recentRate(). Throws RenderInputError for a scene the dataset cannot be drawn with and RenderError for GL
  /// failures.
  image::ImageF render(const std::shared_ptr<const Dataset>& dataset, const Scene& scene, FrameStats* stats = nullptr,
                       const FrameOptions& options = {});

  /// The estimated samples per ms (FrameStats::samplesEstimated over msTotal) of the frames of datasets of `kind`
  /// this engine drew lately (RateGauge); 0 before the first. Any thread may ask.
  double recentRate(DatasetKind kind) const;
  /// The work between two cancellation checkpoints, in ms at the recent rate.
  static constexpr double kCheckpointMs = 30;
  /// The checkpoint interval in samples before a frame of that kind has been timed.
  static constexpr double kFirstCheckpointSamples = 1e6;

  /// The budget a frame of `dataset` is fitted to on this engine (VolumeRenderer::budget: its atlas's slots and the
  /// host cache's bricks), for planning away from the renderer (the server's paging ahead); {} (no limit) for a mesh
  /// or a dataset this engine has not drawn yet. The context must be current.
  BrickBudget brickBudget(const std::shared_ptr<const Dataset>& dataset) const;

  /// GPU memory its renderers hold now (their atlases); never above options.gpuBudgetBytes. Any thread may ask.
  size_t gpuBytes() const;
  /// The most gpuBytes() has been.
  size_t peakGpuBytes() const;
  /// Renderers released to stay within the budget so far.
  uint64_t renderersReleased() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> mImpl;
};

}  // namespace voxbrick::render
