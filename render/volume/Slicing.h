// Slice-plane geometry without GL: the exact box-plane polygon, the CPU mirrors of the GPU slicers, global planes.
//
// A plane is dot(n, x) = d with n pointing from the eye into the scene, so nearer planes have smaller d and
// front-to-back order is increasing d. Every polygon here runs counter-clockwise as seen from the eye looking along
// +n (its right-hand normal is -n), the order slice.vert.glsl emits.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace voxbrick::render {

/// The exact intersection of the box [boxMin, boxMax] with the plane dot(n, x) = d (n non-zero, any length), in
/// double precision and independent of the Rezk-Salama tables: 3 to 6 distinct vertices in order, or empty when the
/// plane misses the box or touches it only at a corner or along an edge. Vertices closer than 64 ulps of the box's
/// scale are merged. Throws RenderInputError on a non-finite input, a zero n or boxMin > boxMax.
std::vector<glm::dvec3> intersectBoxPlane(const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n,
                                          double d);

/// The CPU mirror of slice.vert.glsl: the same tables, the same edge tests in the same order, the same six outputs
/// P0..P5 with repeats where the polygon has fewer corners. Boxes are half-open along n, as in planeIndexRange: a
/// plane with d outside [dot(n, front corner), dot(n, back corner)) gives six copies of the front corner, so a plane
/// through a face shared by two boxes is drawn once. Draw it as triangles through kSliceFan. Throws as
/// intersectBoxPlane.
std::array<glm::dvec3, 6> rezkSalamaPolygon(const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n,
                                            double d);

/// The CPU mirror of the path walk of Zellmann & Lang's slicers (slice_lean.vert.glsl, slice.geom.glsl,
/// slice_even.vert.glsl and slice_odd.geom.glsl): Pp is the first crossing on path p of sliceCornerPaths, in polygon
/// order, or in strip order (kSliceStrip) when `stripOrder`. The same vertices as rezkSalamaPolygon (bit for bit),
/// repeated in other places; half-open along n likewise. Throws as intersectBoxPlane.
std::array<glm::dvec3, 6> pathSlicePolygon(const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n,
                                           double d, bool stripOrder = false);

/// Signed area of a planar polygon, positive when it runs counter-clockwise seen looking along +n (n any length).
double polygonArea(std::span<const glm::dvec3> polygon, const glm::dvec3& n);

/// The indices k of the global planes d_k = k * step that a box gets: dMin <= k * step < dMax, where dMin and dMax
/// are dot(n, x) at its front and back corners. Half-open, so a plane through a face shared by two bricks is drawn
/// by exactly one of them.
struct PlaneIndexRange {
  int64_t begin = 0;  ///< first k
  int64_t end = 0;    ///< one past the last k
  /// How many planes (0 when the box gets none).
  int64_t count() const { return end > begin ? end - begin : 0; }
};

/// The plane indices for one box (a brick or the whole volume) with plane spacing `step` > 0 along n. Throws
/// RenderInputError on a non-finite input, a zero n, step <= 0, boxMin > boxMax, or more than 2^53 planes away from
/// the origin (where k * step stops being exact).
PlaneIndexRange planeIndexRange(const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n, double step);

/// The planes to give slice.vert.glsl for a box: planeIndexRange widened by one plane on each side. The shader
/// decides in float whether each plane lies in the box, and near a face float may put a plane on the other side of
/// it than double did; with the extra plane each side, the box that float says owns it always has it to draw.
PlaneIndexRange slicerPlaneRange(const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n, double step);

/// The globally spaced planes that cut a box, nearest first: plane i is at distance (firstIndex + i) * step.
struct SlicePlanes {
  double first = 0;        ///< distance of the first (nearest) plane: firstIndex * step
  double step = 0;         ///< spacing, > 0
  int64_t count = 0;       ///< number of planes, may be 0
  int64_t firstIndex = 0;  ///< global index k of the first plane
  /// Distance of plane i, computed as (firstIndex + i) * step so that every brick gets bit-identical planes.
  double distance(int64_t i) const { return double(firstIndex + i) * step; }
};

/// The planes d_k = k * step (k an integer, the same for every brick, so slices of neighbouring bricks meet without
/// seams) with dMin <= d_k < dMax over the box; see planeIndexRange. Throws as planeIndexRange.
SlicePlanes globalPlanes(const glm::dvec3& volumeMin, const glm::dvec3& volumeMax, const glm::dvec3& n, double step);

}  // namespace voxbrick::render
