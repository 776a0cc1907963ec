// Renders a tetrahedral mesh (seed 002, Carrard & Juliachs): cells sorted front to back on the CPU (MPVO or by
// centroid, mesh/Visibility.h), then one instance per tet drawn in that order, its quad covering the tet's
// projection, its fragments finding the pixel ray's entry and exit faces and classifying the segment from the
// pre-integrated table (front value, back value, length): shaders/tet.vert.glsl and tet.frag.glsl.
#pragma once

#include <memory>
#include <vector>

#include "render/gl/Compositor.h"
#include "render/core/FrameRenderer.h"
#include "render/gl/GlContext.h"
#include "render/gl/GlObjects.h"
#include "render/gl/PreIntegrationTexture.h"
#include "render/tets/TetMeshDataset.h"
#include "render/gl/tets/TetRayCaster.h"

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
  /// caster; RenderMode::Roofline draws projected tets with the seed's null fragment program). Visibility
  /// TetSort::Ray draws with the ray caster where rayCastable, otherwise projected in MPVO order
  /// (FrameStats::tetRayPasses says which). A paged mesh draws the chunks the frame needs (TetMeshSource::frameData);
  /// a frame that needs none is the background. Throws RenderInputError for an invalid scene, RenderError for GL
  /// failures, FrameCancelled when options.cancelled says so before drawing, and what frameData throws.
  image::ImageF render(const Scene& scene, FrameStats* stats = nullptr, const FrameOptions& options = {}) override;
  size_t gpuBytes() const override;

  /// The GPU bytes a mesh of `tets` tetrahedra takes resident: its vertices, its order and the table.
  static size_t bytesFor(size_t tets);
  /// The least budget a renderer works in: the table and a batch of kMinBatchTets.
  static size_t minimumBytes();
  /// Whether the tets are streamed in batches each frame (the mesh is larger than the budget).
  bool streamed() const { return mStreamed; }

 private:
  static constexpr size_t kBytesPerTet = 64;     // four vec4: position and scalar
  static constexpr size_t kMinBatchTets = 4096;  // the smallest streamed batch
  /// The largest pre-integration table (64 length layers of RGBA32F).
  static size_t tableBytes();
  /// Makes `data` the tets on the GPU (resident, or streamed when larger than the budget).
  void upload(std::shared_ptr<const TetMeshData> data);
  /// Tet `tet`'s four vertices as the shader reads them.
  void writeTet(uint32_t tet, glm::vec4* out) const;
  /// The cost of drawing the tets of mDrawn with `viewProj` into a width x height window, in FrameOptions::maxSamples' unit: the
  /// pixels of each tet's projected bounding box inside the window (an upper bound of its fragments, or of the ray
  /// caster's segments in it; the whole window for a tet reaching behind the eye plane), plus kFragmentsPerTet for
  /// each of `vertexStages` tets drawn projected.
  double estimatedCost(const glm::dmat4& viewProj, int width, int height, size_t vertexStages);
  /// Whether this frame can be ray cast: the mesh is resident, its box lies wholly beyond the near plane (each ray
  /// then meets the mesh first at a boundary face) and the ray caster's buffers fit the budget beside the projected
  /// tets' (made on first use).
  bool rayCastable(const Camera& camera, double nearPlane);
  /// Draws the tets of mOrder projected, with `program` (plain, shaded or null).
  void drawProjected(const TetFrameUniforms& uniforms, const Program& program, FrameStats& stats,
                     const std::function<bool()>& cancelled);

  const Gl& mGl;
  std::shared_ptr<const TetMeshSource> mSource;
  std::shared_ptr<const TetMeshData> mData;  // the tets on the GPU; a paged mesh's only while a frame draws them
  uint64_t mUploaded = 0;                    // the id (TetMeshData::id) of the tets on the GPU; 0 for none
  size_t mGpuBudget = 0;
  bool mStreamed = false;
  size_t mBatchTets = 0;  // tets the vertex buffer holds: all of them, or a streamed batch
  Buffer mVertices;  // 4 vec4 per tet: position (centred on the mesh's box) and raw scalar
  Buffer mOrderBuffer;
  VertexArray mEmpty;  // core profile draws need a vertex array, even one without attributes
  Program mProgram, mNullProgram, mShadedProgram;
  Compositor mCompositor;
  PreIntegrationTexture mTable;
  std::unique_ptr<TetRayCaster> mRayCaster;  // made by the first frame that ray casts
  std::vector<uint32_t> mOrder;       // this frame's tets, front to back
  std::vector<glm::vec4> mStaging;    // a streamed batch on its way to mVertices
  std::vector<glm::vec3> mProjected;  // estimatedCost: each point's window position, z 0 at or behind the eye
  std::vector<uint8_t> mDrawn;        // per tet in mesh order: 1 if this frame draws it (not skipped as empty)
};

}  // namespace voxbrick::render
