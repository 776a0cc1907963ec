// Renders one frame of a brick store: octree traversal, paging into the atlas, slicing, classification and
// front-to-back compositing in float, then the background.
#pragma once

#include <memory>
#include <string>

#include "brickstore/BrickCache.h"
#include "render/BrickAtlas.h"
#include "render/GlContext.h"
#include "render/GlObjects.h"
#include "render/Image.h"
#include "render/Scene.h"
#include "render/SubBlocks.h"

namespace voxbrick::render {

/// What one frame did (DESIGN: every frame reports it).
struct FrameStats {
  int64_t nodesVisited = 0;
  int64_t bricksSkippedEmpty = 0;
  int64_t bricksCulled = 0;
  int64_t bricksDrawn = 0;
  int64_t bricksPagedIn = 0;   ///< uploaded into the atlas this frame
  int64_t bricksEvicted = 0;   ///< replaced in the atlas this frame
  int64_t batches = 0;         ///< draw batches (more than one when the atlas cannot hold the frame's bricks)
  int64_t slices = 0;          ///< brick-plane polygons submitted
  int64_t fragments = 0;       ///< fragments shaded (GL_SAMPLES_PASSED): one volume sample each
  int64_t subBlocksSkipped = 0;  ///< sub-blocks of drawn bricks left out as empty (Scene::subBlock)
  int64_t boxesDrawn = 0;        ///< boxes sliced: bricks, or with sub-blocks the boxes bricks are drawn as
  /// Wall time of each phase on the calling thread. Drawing ends with a glFinish, but with several batches a
  /// batch's GPU work may instead be waited for by the next batch's uploads and show up as paging.
  double msTraversal = 0, msPaging = 0, msSlicing = 0, msDrawing = 0, msReadback = 0, msTotal = 0;
  std::string toJson() const;
};

/// What the fragment stage does: the optical model, or (for benchmarks) exactly one trilinear atlas fetch per
/// fragment with no classification and no blending, the sampling roofline of the same geometry.
enum class RenderMode { Normal, Roofline };

/// One renderer per GL context (so per render thread). It keeps its atlas between frames, so bricks stay resident.
class VolumeRenderer {
 public:
  /// `context` must be current on this thread whenever the renderer is used. `gpuBudgetBytes` bounds the atlas.
  VolumeRenderer(GlContext& context, std::shared_ptr<store::BrickCache> cache, size_t gpuBudgetBytes,
                 AtlasFormat format = AtlasFormat::Float);
  ~VolumeRenderer();

  /// Renders `scene`; throws RenderInputError for an invalid scene and RenderError for GL failures.
  ImageF render(const Scene& scene, FrameStats* stats = nullptr, RenderMode mode = RenderMode::Normal);

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
