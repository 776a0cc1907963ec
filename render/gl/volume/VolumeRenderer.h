// Renders one frame of a brick store, as stages with one job each: the frame plan (FramePlan), residency in the
// atlas (Residency), slice geometry (SliceGeometry), the drawing pass (SlicingPass) with its program
// (VolumePrograms), and compositing with readback (Compositor).
#pragma once

#include <functional>
#include <memory>

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
  /// A frame from planning to statistics, `finish` reading it back (Compositor::finish or finish8); puts the context
  /// back in order if drawing or finishing throws.
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
