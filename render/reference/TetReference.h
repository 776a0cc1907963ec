// The reference renderer of tetrahedral meshes: the optical model of ARCHITECTURE.md integrated exactly through the
// mesh on the CPU in double precision, the judge of the mesh renderers as ReferenceRenderer is of the grid's.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <glm/glm.hpp>

#include "image/Image.h"
#include "mesh/TetMesh.h"
#include "render/core/Camera.h"
#include "render/core/Scene.h"
#include "render/core/TransferFunction.h"
#include "render/tets/TetMeshDataset.h"

namespace voxbrick::render {

/// Everything a mesh reference frame depends on besides the mesh, as the grid reference takes it from a Scene.
struct TetReferenceParams {
  Camera camera;  ///< perspective or orthographic, as Camera defines them (CameraSpec::resolve gives one)
  /// Default: the grayscale ramp, as Scene's.
  TransferFunction transferFunction{{{0.0, {0, 0, 0, 0}}, {0.05, {0.05, 0.05, 0.05, 0}}, {1.0, {1, 1, 1, 0.5}}}};
  /// The value window: raw scalar windowLo maps to 0 and windowHi to 1, linearly, clamped beyond (as the grid's).
  double windowLo = 0, windowHi = 1;
  double referenceLength = 1;  ///< L_ref, world units: alpha is per this length
  int width = 256, height = 256;
  glm::dvec3 background{0.0};  ///< opaque background colour, RGB in [0, 1]
  bool transparent = false;    ///< no background: alpha is the opacity, colour straight (Scene::transparent)
  /// The grids' two-sided Phong headlight (Scene::shading), the normal each tet's scalar gradient: constant along a
  /// segment, as is the direction to the eye, so it shades each pre-integrated segment exactly.
  bool shading = false;

  /// The parameters of `scene` for `mesh`: the scene's camera resolved on the mesh's bounds (its orbit is about
  /// them), its transfer function, size and background, its window or else the mesh's scalar range (a constant mesh
  /// gets [v, v + 1], as a constant store does), and L_ref the transfer function's or `defaultReferenceLength`.
  /// Throws RenderInputError for an invalid scene or an empty mesh.
  static TetReferenceParams fromScene(const Scene& scene, const mesh::TetMesh& mesh, double defaultReferenceLength);
  /// The same for a mesh of `constants` (its box, scalar range and mean edge length): those of the whole mesh when
  /// the reference integrates a part of it (a paged mesh's working set, TetMeshSource::frameData).
  static TetReferenceParams fromScene(const Scene& scene, const TetMeshConstants& constants);
  /// Throws RenderInputError naming the value for an invalid camera, a size outside [1, Scene::kMaxImageSide], a
  /// window that is not finite with lo < hi, L_ref not finite and positive, a background outside [0, 1].
  void validate() const;
};

/// One ray through the mesh. Ties are broken by symbolic perturbation: a ray through an edge, a vertex or in the
/// plane of a face (exactly, or within 1e-12 of its distance to the vertices, which takes in the rounding of rays
/// that are there in exact arithmetic) is taken as moved by eps * right + eps^2 * up for an infinitesimal eps, so it
/// lies inside exactly one of the tets around it, on the same side for every tet (no face counted twice, no gap).
struct TetRay {
  glm::dvec3 origin{0.0};
  glm::dvec3 direction{0.0, 0.0, -1.0};                ///< unit length
  glm::dvec3 right{1.0, 0.0, 0.0}, up{0.0, 1.0, 0.0};  ///< with direction, a basis (the camera's)
  double tNear = 0;  ///< the ray starts here (the near plane); parameters are world lengths along it
};

/// The part of a ray inside one tet, from where it enters (t0) to where it leaves (t1), with the raw scalar there.
struct TetSegment {
  double t0 = 0, t1 = 0;
  double value0 = 0, value1 = 0;
  uint32_t tet = 0;
};

/// What one mesh reference frame did.
struct TetReferenceStats {
  int64_t rays = 0;       ///< rays that met the mesh
  int64_t segments = 0;   ///< tet segments composited (of positive length)
  int64_t tetTests = 0;   ///< exact ray-tet tests (tets whose bounding box the ray meets)
  int64_t ambiguous = 0;  ///< tets whose edge tests fit no line (left out; see TetReference::segments())
  double ms = 0;          ///< wall time, BVH build excluded
};

/// A mesh prepared for reference rays: vertex positions in double, each tet's orientation, and a bounding volume
/// hierarchy over the tets (median splits of their bounding boxes, built once).
///
/// Each pixel's ray (through the pixel centre, as ReferenceRenderer's) is intersected exactly with every tet whose
/// box it meets: Plücker side tests of the ray against the six edges (each edge's test computed once per ray
/// direction from its two vertices in a fixed order, so that the tets sharing an edge or face decide alike) give the
/// face it enters and the face it leaves, and the barycentric weights there give the parameters and the scalar,
/// which is linear inside a tet. Neighbours compute a shared face's point from the same numbers, so their segments
/// meet end to start exactly. Sorted along the ray and cut at the near plane, the segments are composited front to
/// back with integrateSegment (render/core/SegmentIntegral.h): the emission–absorption integral of a linear scalar
/// through the transfer function, exact up to 1e-14 per segment. Gaps (a non-convex mesh, holes) add nothing.
/// Rays run in parallel by rows (oneTBB); a ray stops once its transmittance is below 1e-15.
class TetReference {
 public:
  /// Keeps a reference to nothing of `mesh`. Throws RenderInputError if a tet's index is out of range or the
  /// scalars are not one per vertex. Tets of zero volume are ignored (a ray crosses them in no length).
  explicit TetReference(const mesh::TetMesh& mesh);
  ~TetReference();
  TetReference(TetReference&&) noexcept;
  TetReference& operator=(TetReference&&) noexcept;

  /// The frame: for each pixel the colour over the background (alpha 1) or, with a transparent one, straight colour
  /// and the opacity as alpha (outputPixel), as ReferenceRenderer writes it. Throws RenderInputError from
  /// params.validate().
  image::ImageF render(const TetReferenceParams& params, TetReferenceStats* stats = nullptr) const;
  /// The ray of pixel (x, y) of `params`' image: from the eye (or the view plane) through the pixel centre, starting
  /// at the near plane of the mesh's bounds.
  TetRay pixelRay(const TetReferenceParams& params, int x, int y) const;
  /// The segments of `ray` beyond ray.tNear (cut there), sorted by entry, zero-length ones left out. A tet whose
  /// edge tests, after the tie rule, fit no line (not seen in the tests; conceivable for a sliver whose edges differ
  /// in length by more than 1e4 when the ray runs within 1e-12 of several of them) is left out and counted in
  /// `ambiguous`, if given.
  std::vector<TetSegment> segments(const TetRay& ray, int64_t* ambiguous = nullptr) const;
  /// Premultiplied colour and opacity of `ray` (before the background), integrated as render() does.
  glm::dvec4 integrate(const TetRay& ray, const TetReferenceParams& params) const;
  /// The mesh's bounds in world units.
  Box bounds() const;

 private:
  struct Data;
  std::unique_ptr<Data> mData;
};

/// TetReference(mesh).render(params, stats): builds the BVH and renders one frame.
image::ImageF renderTetReference(const mesh::TetMesh& mesh, const TetReferenceParams& params,
                                 TetReferenceStats* stats = nullptr);

}  // namespace voxbrick::render
