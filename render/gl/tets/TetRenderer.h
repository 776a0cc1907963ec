// Renders a tetrahedral mesh (Carrard & Juliachs) in stages: the plan (TetFramePlan, GL-free), the frame's
// tets on the GPU (TetResidency), the visibility order on the CPU (TetOrder: MPVO or by centroid, mesh/Visibility.h,
// less the empty tets), the cost check (TetFrameCost), then a pass: the ray caster (TetRayCaster) or the projected
// tets drawn here, one instance per tet in visibility order, its quad covering the tet's projection, its fragments
// finding the pixel ray's entry and exit faces and classifying the segment from the pre-integrated table (front
// value, back value, length): shaders/tet.vert.glsl and tet.frag.glsl.
#pragma once

#include <chrono>
#include <memory>
#include <vector>

#include "render/core/FrameRenderer.h"
#include "render/gl/Compositor.h"
#include "render/gl/GlContext.h"
#include "render/gl/GlObjects.h"
#include "render/gl/PreIntegrationTexture.h"
#include "render/gl/tets/TetRayCaster.h"
#include "render/gl/tets/TetResidency.h"
#include "render/tets/TetFrameCost.h"
#include "render/tets/TetFramePlan.h"
#include "render/tets/TetMeshDataset.h"
#include "render/tets/TetOrder.h"

namespace voxbrick::render {

/// One per GL context and mesh. The tets stay on the GPU between frames (64 bytes each: four vertices as position
/// and scalar), as does the pre-integrated table while the transfer function and the lengths stay the same; each
/// frame uploads only the order (4 bytes a tet).
class TetRenderer final : public FrameRenderer {
 public:
  /// Draws the tets of `source`: a whole mesh is uploaded now, a paged one's working set when a frame first needs it
  /// (and again when a frame needs another). Tets are uploaded when they fit `gpuBudgetBytes` (bytesFor); otherwise
  /// each frame streams them, in visibility order, through a buffer of as many as the budget holds (the same image,
  /// a batch per draw). Throws RenderInputError when the budget is below minimumBytes().
  TetRenderer(GlContext& context, std::shared_ptr<const TetMeshSource> source, size_t gpuBudgetBytes);
  /// The same for a whole mesh held in memory.
  TetRenderer(GlContext& context, std::shared_ptr<const TetMeshData> whole, size_t gpuBudgetBytes)
      : TetRenderer(context, std::make_shared<const TetMeshSource>(std::move(whole)), gpuBudgetBytes) {}
  ~TetRenderer() override;

  /// Renders `scene` (camera, size, transfer function, window, background, visibility, shading, ert for the ray
  /// caster; RenderMode::Roofline draws projected tets with Carrard & Juliachs' null fragment program). Visibility
  /// TetSort::Ray draws with the ray caster where rayCastable, otherwise projected in MPVO order
  /// (FrameStats::tetRayPasses says which). A paged mesh draws the chunks the frame needs (TetMeshSource::frameData);
  /// a frame that needs none is the background. With options.meshPart (sort-last rendering): only the cells that
  /// meet the part's box, drawn as the whole frame would be (ray cast or projected) with each ray's integration
  /// clipped to the box (FrameStats::tetPart says which), premultiplied with no background. Throws
  /// RenderInputError for an invalid scene, a grid's options.part, a meshPart that is no box or with
  /// RenderMode::Roofline, RenderError for GL failures, FrameCancelled when options.cancelled says so before
  /// drawing, and what frameData throws.
  image::ImageF render(const Scene& scene, FrameStats* stats = nullptr, const FrameOptions& options = {}) override;
  /// The same frame finished on the GPU as 8 bits (Compositor::finish8).
  image::Image8 render8(const Scene& scene, FrameStats* stats = nullptr, const FrameOptions& options = {}) override;
  size_t gpuBytes() const override;
  /// The cost model's estimate (TetFrameCost) of the last frame, its fragments scaled to `scene`'s size; before any
  /// frame, the vertex stages of every tet and one fragment a pixel.
  double estimateSamples(const Scene& scene) override;

  /// The GPU bytes a mesh of `tets` tetrahedra takes resident: its vertices, its order and the table.
  static size_t bytesFor(size_t tets);
  /// The least budget a renderer works in: the table and a batch of kMinBatchTets.
  static size_t minimumBytes();
  /// Whether the tets are streamed in batches each frame (the mesh is larger than the budget).
  bool streamed() const { return mResidency.streamed(); }

 private:
  using TimePoint = std::chrono::steady_clock::time_point;
  static constexpr size_t kBytesPerTet = TetResidency::kBytesPerTet;
  /// Uploads the tets held (TetResidency::hold) for the projected pass: all of them, or the streamed batch's buffer.
  void upload();
  /// Tet `tet`'s four vertices as the shader reads them.
  void writeTet(uint32_t tet, glm::vec4* out) const;
  /// The compositor's readback: as floats (a part's premultiplied, with no background), or during render8 as 8 bits
  /// into *mFrame8 (the floats returned empty).
  image::ImageF finishFrame(const Scene& scene, FrameStats& stats, bool part);
  /// A frame with nothing to draw (a part's: transparent).
  image::ImageF background(const Scene& scene, FrameStats& stats, bool part, TimePoint frameStart,
                           FrameStats* statsOut);
  /// The projected tets' program: plain or shaded, whole or clipped to a part (those made on the first part's frame).
  const Program& projectedProgram(bool shading, bool part);
  /// The table, the pass (the ray caster when `rays`, else the projected tets of mOrder) and the readback.
  image::ImageF draw(const Scene& scene, const TetFramePlan& plan, bool rays, FrameStats& stats,
                     const FrameOptions& options, TimePoint frameStart, FrameStats* statsOut);
  /// Draws the tets of mOrder projected, with `program` (plain, shaded or null).
  void drawProjected(const TetFrameUniforms& uniforms, const Program& program, FrameStats& stats,
                     const std::function<bool()>& cancelled);

  const Gl& mGl;
  image::Image8* mFrame8 = nullptr;  // during render8: where the frame's 8 bits go
  TetResidency mResidency;
  Buffer mVertices;  // 4 vec4 per tet: position (centred on the mesh's box) and raw scalar
  Buffer mOrderBuffer;
  VertexArray mEmpty;  // core profile draws need a vertex array, even one without attributes
  Program mProgram, mNullProgram, mShadedProgram;
  Program mPartProgram, mShadedPartProgram;  // empty until a part's frame needs them
  Compositor mCompositor;
  double mLastVertexCost = 0, mLastFragmentCost = 0, mLastPixels = 0;  // the last frame's estimate, for estimateSamples
  PreIntegrationTexture mTable;
  TetOrder mOrder;  // this frame's tets, front to back
  TetFrameCost mCost;
  std::vector<glm::vec4> mStaging;  // a streamed batch on its way to mVertices
};

}  // namespace voxbrick::render
