// The adjacency ray caster of tetrahedral meshes: instead of sorting the tets and drawing each one's projection
// (render/gl/tets/TetRenderer.h, Carrard & Juliachs), each pixel's ray is walked through the mesh tet to tet across the
// faces it leaves through (the face-adjacency graph of mesh/Topology.h), from the boundary face where it enters
// (Garrity 1990; Weiler et al. 2003 on the GPU). The segments are those of the projected tets, classified the same way
// from the pre-integrated table, so the image is the same model; what changes is the work: no sort, no vertex stage per
// tet and no blending per segment, and a ray stops where its opacity reaches the termination threshold.
//
// A frame is a few passes. An entry pass rasterises the boundary faces; each fragment where the ray enters the
// mesh beyond where the last pass left it keeps the nearest (shaders/tet_entry.frag.glsl). A ray pass then walks
// every pixel that found an entry to where the ray leaves the mesh, and blends its colour under the passes before
// it (shaders/tet_ray.frag.glsl). A convex mesh takes one pass (and an entry pass that finds nothing); a
// non-convex one a pass per re-entry of the ray (depth peeling of the boundary).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "render/core/FrameStats.h"
#include "render/core/PixelRays.h"
#include "render/core/PreIntegration.h"
#include "render/gl/Bands.h"
#include "render/gl/Compositor.h"
#include "render/gl/GlObjects.h"
#include "render/gl/SampleCounters.h"
#include "render/tets/TetMeshDataset.h"

namespace voxbrick::render {

/// What both mesh renderers' programs are given for a frame (shaders/tet*.glsl): the camera's matrix and pixel
/// rays, the value window and the pre-integrated table's mapping.
struct TetFrameUniforms {
  glm::dmat4 viewProj{1.0};  ///< world, centred on the mesh's box, to clip
  PixelRays rays;
  int width = 0, height = 0;
  double windowLo = 0, windowScale = 1;  ///< the value window as lo and 1 / (hi - lo)
  double reference = 1;                  ///< the transfer function's reference length
  PreIntegrationSpec table;
  /// A sort-last part's frame (FrameOptions::meshPart): its box, centred on the mesh's box as the vertices are; the
  /// programs are then the PART_CLIP ones, which clip each ray's integration to it.
  bool part = false;
  glm::dvec3 partLo{0.0}, partHi{0.0};
};

/// Sets `uniforms` on `program` (uniforms it does not have are ignored).
void setTetUniforms(const Program& program, const TetFrameUniforms& uniforms);

/// One per GL context and mesh: each tet's vertices in the order of their indices (64 bytes a tet) and its neighbours
/// (16 bytes), and the boundary faces (52 bytes each), uploaded once.
class TetRayCaster {
 public:
  /// The most tets it takes: a neighbour is coded as tet * 8 + orientation * 4 + face in 31 bits.
  static constexpr size_t kMaxTets = size_t(1) << 28;

  /// Uploads `data`'s tets and boundary. Throws RenderInputError for a mesh of more than kMaxTets, RenderError for GL
  /// failures.
  TetRayCaster(const Gl& gl, const TetMeshData& data);
  ~TetRayCaster();

  /// The GPU bytes a mesh of `tets` tetrahedra and `boundaryFaces` boundary faces takes.
  static size_t bytesFor(size_t tets, size_t boundaryFaces);
  size_t gpuBytes() const { return mBytes; }

  /// Draws a frame into `compositor` (begun, blending front to back), the pre-integrated table bound on
  /// VB_UNIT_PRE_INTEGRATED (the unit tet.glsl declares). `termination`: the opacity where a ray stops (0: never).
  /// `compute`: each ray pass is the compute kernel (shaders/tet_ray.comp.glsl, dispatched in tiles of workgroups,
  /// each invocation compositing its pixel into the target itself) instead of the fragment kernel blended; the same
  /// walk, the same image.
  /// With uniforms.part, each ray is integrated only inside the part's box and stops once past it.
  /// Counts the entry passes in stats.tetRayPasses; `cancelled` is checked between passes and between bands of 64 rows
  /// of a ray pass (throwing FrameCancelled), bands sized by stats.samplesEstimated to about `checkpointSamples`
  /// each (FrameOptions::checkpointSamples; 0: 64 rows). Leaves the compositor's target bound.
  void draw(const TetFrameUniforms& uniforms, double termination, bool shading, bool compute, Compositor& compositor,
            FrameStats& stats, const std::function<bool()>& cancelled, double checkpointSamples = 0);
  /// After the compositor's finish: the frame's counts into stats.fragments (rays walked: one per pixel and pass
  /// that found an entry), samples (tets walked with a segment of positive length) and samplesTerminated (rays
  /// stopped by the threshold).
  void readCounters(FrameStats& stats) const;

 private:
  /// The entry pass's target of `width` x `height`: the entry (R32UI) and its depth.
  void prepareTargets(int width, int height);
  /// Uploads each tet's vertices in the order of their indices; sets `newIndex` (where each stored vertex went in
  /// that order) and `reversed` (1 where that order is negatively oriented), per tet.
  void uploadVertices(const TetMeshData& data, std::vector<std::array<uint8_t, 4>>& newIndex,
                      std::vector<uint8_t>& reversed);
  /// Uploads each tet's neighbour across each of its faces, coded, in that order.
  void uploadNeighbours(const mesh::Topology& topology, const std::vector<std::array<uint8_t, 4>>& newIndex,
                        const std::vector<uint8_t>& reversed);
  /// Uploads the boundary faces: their corners and each one's tet and face, coded.
  void uploadBoundary(const TetMeshData& data, const std::vector<std::array<uint8_t, 4>>& newIndex,
                      const std::vector<uint8_t>& reversed);

  const Gl& mGl;
  size_t mTets = 0;
  size_t mBoundaryFaces = 0;
  size_t mBytes = 0;
  Buffer mVertices;    // per tet four vec4 (position, raw scalar), in the order of their indices in the mesh
  Buffer mNeighbours;  // per tet, across each face: the neighbour and its face, coded, or -1
  Buffer mCorners;     // three vec4 per boundary face
  Buffer mFaces;       // per boundary face its tet and face, coded
  Buffer mExits;       // per pixel: where the last pass left the mesh
  std::vector<float> mBeforeMesh;  // its contents at the start of a frame, kept with the target's size
  Buffer mEntryCount;              // fragments the entry pass kept
  /// The ray pass's program: plain or shaded, whole or clipped to a part, fragment or compute kernel (those but the
  /// whole frame's fragment kernels made on the first frame that needs them).
  const Program& rayProgramFor(bool shading, bool part, bool compute);

  Program mEntryProgram;
  Program mRayPrograms[2][2][2];  // [compute][part][shading]
  Framebuffer mEntryTarget;
  Texture mEntryTexture, mEntryDepth;
  int mWidth = 0, mHeight = 0;
  VertexArray mEmpty;
  SampleCounters mCounters;
};

}  // namespace voxbrick::render
