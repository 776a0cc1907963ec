// Renders one frame of a brick store, as stages with one job each: the frame plan (FramePlan), residency in the
// atlas (Residency), slice geometry (SliceGeometry), the drawing pass (SlicingPass) with its program
// (VolumePrograms), and compositing with readback (Compositor).
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <span>

#include "brickstore/read/BrickCache.h"
#include "render/core/FrameRenderer.h"
#include "render/gl/Compositor.h"
#include "render/gl/GlContext.h"
#include "render/gl/GlObjects.h"
#include "render/gl/PreIntegrationTexture.h"
#include "render/gl/volume/BrickAtlas.h"
#include "render/gl/volume/RayCastPass.h"
#include "render/gl/volume/Residency.h"
#include "render/gl/volume/SlabPass.h"
#include "render/gl/volume/SliceGeometry.h"
#include "render/gl/volume/SlicingPass.h"
#include "render/gl/volume/VolumePrograms.h"
#include "render/volume/FramePlan.h"

namespace voxbrick::render {

/// One renderer per GL context (so per render thread). It keeps its atlas between frames, so bricks stay resident.
class VolumeRenderer final : public FrameRenderer {
 public:
  /// `context` must be current on this thread whenever the renderer is used. `gpuBudgetBytes` bounds the atlas.
  VolumeRenderer(GlContext& context, std::shared_ptr<store::BrickCache> cache, size_t gpuBudgetBytes,
                 AtlasFormat format = AtlasFormat::Float, AtlasUploads uploads = AtlasUploads::Auto,
                 AtlasBricking bricking = AtlasBricking::Single);
  ~VolumeRenderer() override;

  /// Renders `scene`; throws RenderInputError for an invalid scene and RenderError for GL failures.
  image::ImageF render(const Scene& scene, FrameStats* stats = nullptr, const FrameOptions& options = {}) override;
  /// The frame finished on the GPU as 8-bit RGBA (Compositor::finish8); a part's frame (options.part) is converted
  /// on the CPU as FrameRenderer's default does.
  image::Image8 render8(const Scene& scene, FrameStats* stats = nullptr, const FrameOptions& options = {}) override;
  /// Each scene's frame as render8 draws it, the next frame planned on the CPU while the GPU draws this one (a
  /// frame's msTotal is its planning and its drawing to its readback, not the wait for the frame before it). Frames
  /// with stand-ins, parts or cancellation are drawn one after the other.
  void renderSequence8(std::span<const Scene> scenes, const FrameOptions& options,
                       const FrameDelivery& deliver) override;

  const BrickAtlas& atlas() const { return mResidency.atlas(); }
  /// The ray caster's cell table as the last ray-cast frame left it.
  const CellTable& cellTable() const { return mRayCast.cells(); }
  size_t gpuBytes() const override { return mResidency.atlas().bytes(); }
  /// The plan's estimate (FramePlan::estimatedSamples) of `scene` under this renderer's budget.
  double estimateSamples(const Scene& scene) override;

  /// What a frame's bricks must fit: the atlas's slots, and the bricks the host cache's budget holds now.
  BrickBudget budget() const;

  /// Texels of the GPU's transfer-function table.
  static constexpr int kTransferTableTexels = render::kTransferTableTexels;

 private:
  SliceGeometry& geometry(const Scene& scene);
  /// The plan's part of the frame's statistics: the traversal's counts and the fit to the budget.
  void planStats(const FramePlan& plan, FrameStats& stats) const;
  /// A frame planned (GL-free: the octree walk, the estimate and its limits) and not yet drawn.
  struct PlannedFrame {
    FramePlan plan;
    FrameStats stats;
    std::chrono::steady_clock::time_point start;  // when its planning began
    double planningMs = 0;                         // how long it took
  };
  PlannedFrame plan(const Scene& scene, const FrameOptions& options);
  /// Draws a planned frame, calls `whileDrawing` (if any) once its GL work is queued, and `finish` to read it back
  /// (Compositor::finish or finish8); the frame's statistics end in p.stats. Puts the context back in order if
  /// drawing or finishing throws.
  void run(const Scene& scene, PlannedFrame& p, const FrameOptions& options, const std::function<void()>& whileDrawing,
           const std::function<void(const FramePlan&, FrameStats&)>& finish);
  /// plan and run.
  void frame(const Scene& scene, FrameStats* stats, const FrameOptions& options,
             const std::function<void(const FramePlan&, FrameStats&)>& finish);
  /// The GL part of a frame, from paging to the last pass.
  void draw(const Scene& scene, const FramePlan& plan, const FrameOptions& options, FrameStats& stats);

  const Gl& mGl;
  Residency mResidency;
  Texture mTransfer;
  VolumePrograms mPrograms;
  // One per slicer (by the Slicer's value), then slabs; made on first use.
  std::unique_ptr<SliceGeometry> mGeometry[kSlicers.size() + 1];
  SlicingPass mSlicing;
  Compositor mCompositor;
  SlabPass mSlabs;
  RayCastPass mRayCast;
  PreIntegrationTexture mPreIntegration;
  bool mComputeByDefault;  // RayCaster::Auto's kernel on this context's device
};

}  // namespace voxbrick::render
