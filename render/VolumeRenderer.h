// Renders one frame of a brick store: octree traversal, paging into the atlas, slicing, classification and
// front-to-back compositing in float, then the background.
#pragma once

#include <memory>
#include <string>

#include "brickstore/BrickCache.h"
#include "render/BrickAtlas.h"
#include "render/FrameRenderer.h"
#include "render/GlContext.h"
#include "render/GlObjects.h"
#include "render/Image.h"
#include "render/Scene.h"
#include "render/SubBlocks.h"

namespace voxbrick::render {

/// One renderer per GL context (so per render thread). It keeps its atlas between frames, so bricks stay resident.
class VolumeRenderer final : public FrameRenderer {
 public:
  /// `context` must be current on this thread whenever the renderer is used. `gpuBudgetBytes` bounds the atlas.
  VolumeRenderer(GlContext& context, std::shared_ptr<store::BrickCache> cache, size_t gpuBudgetBytes,
                 AtlasFormat format = AtlasFormat::Float);
  ~VolumeRenderer();

  /// Renders `scene`; throws RenderInputError for an invalid scene and RenderError for GL failures.
  ImageF render(const Scene& scene, FrameStats* stats = nullptr, RenderMode mode = RenderMode::Normal) override;

  const BrickAtlas& atlas() const { return mAtlas; }

 private:
  struct Batch;
  void drawBatch(Batch& batch, const Program& program, Slicer slicer, FrameStats& stats);
  const Program& program(Slicer slicer, bool shading, bool roofline, bool exactOwnership);

  const Gl& mGl;
  std::shared_ptr<store::BrickCache> mCache;
  BrickAtlas mAtlas;
  Texture mTransfer;
  Buffer mInstances;
  Buffer mVertices;
  VertexArray mVertexArray;
  Framebuffer mTarget;
  Query mFragments;
  std::vector<SubBlockRanges> mSlotRanges;  // per atlas slot: sub-block ranges of the brick it holds
  Program mPrograms[2][3][2];  // [slicer][plain, shading, roofline][exact ownership], built on first use
};

}  // namespace voxbrick::render
