// The one copy of the slicers' lookup tables and vertex layouts, shared by the GPU slicers (as uniforms) and the CPU
// mirrors in Slicing.cpp.
//
// Box corners are numbered by bits: corner c sits at (c & 1 ? max.x : min.x, c & 2 ? max.y : min.y,
// c & 4 ? max.z : min.z). For a plane normal n (pointing from the eye into the scene) the front corner, the one with
// the smallest dot(n, x), has bit i set exactly when n[i] < 0 (sliceFrontIndex), and the back corner is front ^ 7.
//
// Rezk-Salama & Kolb (VMV 2005) name the corners V0..V7 relative to the front corner V0: V7 is the back corner, and
// the three edge paths V0-V1-V4-V7, V0-V2-V5-V7, V0-V3-V6-V7 are disjoint, with the "dotted" edges V1-V5, V2-V6 and
// V3-V4 between them. kSliceSequence[front * 8 + i] is the box corner playing Vi when `front` is the front corner.
// Each row is chosen so that (V1 - V0, V2 - V0, V3 - V0) is a left-handed frame, the paper's choice; that makes
// P0..P5 run counter-clockwise as seen from the eye looking along +n (the polygon's right-hand normal is -n), so
// slices are front-facing under GL's default glFrontFace(GL_CCW) with an unmirrored view.
// The table printed by Zellmann & Lang (listing 1) belongs to a corner numbering neither paper gives, so this one is
// derived from the definition above and checked by the static_asserts below.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include <glm/glm.hpp>

namespace voxbrick::render {

/// kSliceSequence[front * 8 + i]: the box corner that plays the paper's Vi when `front` is the front corner.
inline constexpr std::array<int, 64> kSliceSequence = {
    0, 1, 4, 2, 3, 5, 6, 7,  // front 0
    1, 0, 3, 5, 4, 2, 7, 6,  // front 1
    2, 3, 0, 6, 7, 1, 4, 5,  // front 2
    3, 2, 7, 1, 0, 6, 5, 4,  // front 3
    4, 5, 6, 0, 1, 7, 2, 3,  // front 4
    5, 4, 1, 7, 6, 0, 3, 2,  // front 5
    6, 7, 2, 4, 5, 3, 0, 1,  // front 6
    7, 6, 5, 3, 2, 4, 1, 0,  // front 7
};

/// kSliceEdgeStart[p * 4 + e], kSliceEdgeEnd[p * 4 + e]: the e-th edge (Va -> Vb, in path numbering) that polygon
/// vertex Pp tests; the first edge with the plane between its ends wins. P0, P2, P4 walk a path; P1, P3, P5 test
/// their dotted edge first and then fall back to the path of P0, P2, P4. The paper's v1/v2, except that the unused
/// fourth entry of a 3-edge path repeats its last edge instead of holding -1, so no lookup can go out of bounds.
inline constexpr std::array<int, 24> kSliceEdgeStart = {0, 1, 4, 4, 1, 0, 1, 4, 0, 2, 5, 5,
                                                        2, 0, 2, 5, 0, 3, 6, 6, 3, 0, 3, 6};
inline constexpr std::array<int, 24> kSliceEdgeEnd = {1, 4, 7, 7, 5, 1, 4, 7, 2, 5, 7, 7,
                                                      6, 2, 5, 7, 3, 6, 7, 7, 4, 3, 6, 7};

/// kSlicePaths[p * 4 + k]: the k-th corner (in path numbering V0..V7) of the path that polygon vertex Pp walks in
/// Zellmann & Lang's variants (their listing 2): every path runs V0 -> V7 along three edges, the three of the paper
/// for P0, P2, P4, and for P1, P3, P5 the path that leaves P(p-1)'s path after its first edge along the dotted edge
/// (V1-V5, V2-V6, V3-V4). Each path crosses every plane between V0 and V7 once, so Pp needs at most three edge tests;
/// an odd vertex whose dotted edge misses the plane lands on a neighbour (P1 on P0 or P2, and so on), where
/// kSliceEdgeStart/kSliceEdgeEnd repeat the even vertex before it: the same polygon with the repeats elsewhere.
inline constexpr std::array<int, 24> kSlicePaths = {0, 1, 4, 7, 0, 1, 5, 7, 0, 2, 5, 7,
                                                    0, 2, 6, 7, 0, 3, 6, 7, 0, 3, 4, 7};

/// kSliceStrip[s]: the polygon vertex Pp emitted s-th by the geometry program's triangle strip (slice.geom.glsl).
/// The strip zigzags between the chains P0 -> P1 -> P2 -> P3 and P0 -> P5 -> P4 -> P3, so its four triangles
/// (P0,P1,P5) (P1,P2,P5) (P5,P2,P4) (P2,P3,P4) run counter-clockwise like the fan, and an odd vertex repeating a
/// neighbour only empties a triangle.
inline constexpr std::array<int, 6> kSliceStrip = {0, 1, 5, 2, 4, 3};

/// The path table of the vertex-lean, geometry and vertex-geometry slicers for front corner `front`: kSlicePaths
/// with each path corner replaced by the box corner that plays it (kSliceSequence), rows in polygon order (P0..P5),
/// or in strip order (kSliceStrip) when `stripOrder`. The CPU computes it once per view direction, so the programs
/// hold this one table and look nothing else up.
constexpr std::array<int, 24> sliceCornerPaths(int front, bool stripOrder) {
  std::array<int, 24> paths{};
  for (int row = 0; row < 6; ++row) {
    const int p = stripOrder ? kSliceStrip[size_t(row)] : row;
    for (int k = 0; k < 4; ++k)
      paths[size_t(row * 4 + k)] = kSliceSequence[size_t(front * 8 + kSlicePaths[size_t(p * 4 + k)])];
  }
  return paths;
}

/// Vertices drawn per polygon: the fan (P0,P1,P2) (P0,P2,P3) (P0,P3,P4) (P0,P4,P5) as GL_TRIANGLES; repeated
/// polygon vertices make degenerate triangles that rasterise nothing.
inline constexpr int kSliceVerticesPerPolygon = 12;

/// kSliceFan[gl_VertexID % 12]: which polygon vertex P0..P5 a drawn vertex is (slice.vert.glsl has the same list).
inline constexpr std::array<int, 12> kSliceFan = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5};

/// The front corner for plane normal n: bit i set iff n[i] < 0 (a zero component picks the lower corner; either
/// choice is valid there, as the edges along that axis are parallel to the plane).
constexpr int sliceFrontIndex(double nx, double ny, double nz) {
  return (nx < 0 ? 1 : 0) | (ny < 0 ? 2 : 0) | (nz < 0 ? 4 : 0);
}

/// A slicer table uniform: its GLSL name in slice.vert.glsl and its values. Upload every entry of kSliceTableUniforms
/// once per program (Program::set(program.requireUniform(u.name), u.values)).
struct SliceTableUniform {
  const char* name;
  std::span<const int> values;
};

/// The tables as slice.vert.glsl declares them (int uSequence[64], int uEdgeStart[24], int uEdgeEnd[24]).
inline constexpr std::array<SliceTableUniform, 3> kSliceTableUniforms = {{
    {"uSequence", kSliceSequence},
    {"uEdgeStart", kSliceEdgeStart},
    {"uEdgeEnd", kSliceEdgeEnd},
}};

/// The uniform of the vertex-lean, geometry and vertex-geometry slicers holding sliceCornerPaths (int uPaths[24]),
/// set with the other per-frame uniforms.
inline constexpr const char* kSlicePathsUniform = "uPaths";

/// Vertices drawn per plane of an instance by the geometry-program slicers (the vertex programs draw
/// kSliceVerticesPerPolygon): one point (slice_point.vert.glsl into slice.geom.glsl, GL_POINTS), and the triangle
/// P0, P2, P4 (slice_even.vert.glsl into slice_odd.geom.glsl, GL_TRIANGLES).
inline constexpr int kSlicePointVerticesPerPlane = 1;
inline constexpr int kSliceEvenVerticesPerPlane = 3;

/// The per-frame uniforms of slice.vert.glsl: vec3 plane normal n (unit, from the eye into the scene), float
/// distance between consecutive global planes, mat4 view-projection (world to clip).
inline constexpr const char* kSliceNormalUniform = "uPlaneNormal";
inline constexpr const char* kSlicePlaneIncrUniform = "uPlaneIncr";
inline constexpr const char* kSliceViewProjUniform = "uViewProj";

/// One instance of the slicer draw: a world-space box, a run of planes, and ints passed through untouched to the
/// fragment stage as flat varyings (the atlas slot and the voxels the box owns, for instance). The instance's
/// vertices [12 * i, 12 * i + 12) are the polygon of plane i: dot(n, x) = planeDistance + (firstPlane + i) *
/// uPlaneIncr. For the globally spaced planes of ARCHITECTURE.md set planeDistance = 0 and firstPlane = the global
/// index k of the first plane (slicerPlaneRange(...).begin): plane k then has the same float distance in every brick. A
/// draw of 12 vertices per instance slices each box once, 12 * N vertices N times; planes outside the half-open slab
/// [front, back) of the box (a plane through its back face included) collapse to a point. All seven attributes
/// have divisor 1.
struct SliceInstance {
  glm::vec3 boxMin;     ///< location 0, 3 x GL_FLOAT
  glm::vec3 boxMax;     ///< location 1, 3 x GL_FLOAT
  float planeDistance;  ///< location 2, 1 x GL_FLOAT: added to every plane's distance (0 for global planes)
  glm::ivec4 payload;   ///< location 3, 4 x GL_INT through glVertexAttribIPointer
  int32_t firstPlane;   ///< location 4, 1 x GL_INT through glVertexAttribIPointer: global index of plane 0
  glm::ivec3 ownLo;     ///< location 5, 3 x GL_INT: first voxel the box owns (flat vOwnLo)
  glm::ivec3 ownHi;     ///< location 6, 3 x GL_INT: one past the last voxel it owns (flat vOwnHi)
};
inline constexpr int kSliceBoxMinLocation = 0;
inline constexpr int kSliceBoxMaxLocation = 1;
inline constexpr int kSlicePlaneDistanceLocation = 2;
inline constexpr int kSlicePayloadLocation = 3;
inline constexpr int kSliceFirstPlaneLocation = 4;
inline constexpr int kSliceOwnLoLocation = 5;
inline constexpr int kSliceOwnHiLocation = 6;
static_assert(sizeof(SliceInstance) == 72, "SliceInstance is tightly packed: 3 + 3 + 1 floats, 4 + 1 + 3 + 3 ints");
static_assert(offsetof(SliceInstance, boxMax) == 12 && offsetof(SliceInstance, planeDistance) == 24 &&
                  offsetof(SliceInstance, payload) == 28 && offsetof(SliceInstance, firstPlane) == 44 &&
                  offsetof(SliceInstance, ownLo) == 48 && offsetof(SliceInstance, ownHi) == 60,
              "SliceInstance offsets changed");

/// One vertex of the CPU slicer's draw (slice_cpu.vert.glsl): a corner of a polygon computed by rezkSalamaPolygon,
/// with its box's payload, the global index of its plane and the voxels the box owns (what slice.vert.glsl would
/// output for it). Drawn as GL_TRIANGLES through kSliceFan, no instancing. The locations are those of SliceInstance
/// for the same data.
struct SliceVertex {
  float world[3];      ///< location 0, 3 x GL_FLOAT
  int32_t payload[4];  ///< location 3, 4 x GL_INT
  int32_t plane;       ///< location 4, 1 x GL_INT: global index of the vertex's plane
  int32_t ownLo[3];    ///< location 5, 3 x GL_INT
  int32_t ownHi[3];    ///< location 6, 3 x GL_INT
};
inline constexpr int kSliceVertexWorldLocation = 0;
inline constexpr int kSliceVertexPayloadLocation = 3;
inline constexpr int kSliceVertexPlaneLocation = 4;
inline constexpr int kSliceVertexOwnLoLocation = 5;
inline constexpr int kSliceVertexOwnHiLocation = 6;
static_assert(sizeof(SliceVertex) == 56 && offsetof(SliceVertex, payload) == 12 && offsetof(SliceVertex, plane) == 28 &&
                  offsetof(SliceVertex, ownLo) == 32 && offsetof(SliceVertex, ownHi) == 44,
              "SliceVertex offsets changed");

/// One instance of the slab draw (slab.vert.glsl): a box, drawn as its 12 triangles (36 vertices, back faces kept),
/// and the run of global planes [firstPlane, firstPlane + planeCount) its fragments march. Locations as in
/// SliceInstance where the data is the same; all attributes have divisor 1.
struct SlabInstance {
  glm::vec3 boxMin;    ///< location 0, 3 x GL_FLOAT
  glm::vec3 boxMax;    ///< location 1, 3 x GL_FLOAT
  glm::ivec4 payload;  ///< location 3, 4 x GL_INT
  int32_t firstPlane;  ///< location 4, 1 x GL_INT: global index of the slab's first plane
  glm::ivec3 ownLo;    ///< location 5, 3 x GL_INT
  glm::ivec3 ownHi;    ///< location 6, 3 x GL_INT
  int32_t planeCount;  ///< location 7, 1 x GL_INT
};
inline constexpr int kSlabPlaneCountLocation = 7;
/// Vertices drawn per slab instance: the box's 12 triangles.
inline constexpr int kSlabVerticesPerBox = 36;
static_assert(sizeof(SlabInstance) == 72 && offsetof(SlabInstance, payload) == 24 &&
                  offsetof(SlabInstance, firstPlane) == 40 && offsetof(SlabInstance, ownLo) == 44 &&
                  offsetof(SlabInstance, ownHi) == 56 && offsetof(SlabInstance, planeCount) == 68,
              "SlabInstance offsets changed");

namespace detail {

constexpr bool sliceCornersAdjacent(int a, int b) {
  const int diff = a ^ b;
  return diff == 1 || diff == 2 || diff == 4;
}

// det(V1 - V0, V2 - V0, V3 - V0) on the unit cube, for the left-handedness check.
constexpr int sliceFrameDeterminant(const int* row) {
  int v[3][3] = {};
  for (int k = 0; k < 3; ++k) {
    for (int axis = 0; axis < 3; ++axis) v[k][axis] = ((row[k + 1] >> axis) & 1) - ((row[0] >> axis) & 1);
  }
  return v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1]) - v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0]) +
         v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]);
}

constexpr bool sliceTablesValid() {
  constexpr int pathEdges[12][2] = {{0, 1}, {1, 4}, {4, 7}, {0, 2}, {2, 5}, {5, 7},
                                    {0, 3}, {3, 6}, {6, 7}, {1, 5}, {2, 6}, {3, 4}};
  for (int front = 0; front < 8; ++front) {
    const int* row = kSliceSequence.data() + front * 8;
    if (row[0] != front || row[7] != (front ^ 7)) return false;
    int seen = 0;
    for (int i = 0; i < 8; ++i) seen |= 1 << row[i];
    if (seen != 0xff) return false;
    for (const auto& edge : pathEdges) {
      if (!sliceCornersAdjacent(row[edge[0]], row[edge[1]])) return false;
    }
    if (sliceFrameDeterminant(row) != -1) return false;
  }
  for (int p = 0; p < 6; ++p) {
    for (int e = 0; e < 4; ++e) {
      const int a = kSliceEdgeStart[p * 4 + e];
      const int b = kSliceEdgeEnd[p * 4 + e];
      bool isEdge = false;
      for (const auto& edge : pathEdges) isEdge = isEdge || (edge[0] == a && edge[1] == b);
      if (!isEdge) return false;
    }
  }
  for (int p = 0; p < 6; ++p) {
    const int* path = kSlicePaths.data() + p * 4;
    if (path[0] != 0 || path[3] != 7) return false;
    for (int k = 0; k < 3; ++k) {
      bool isEdge = false;
      for (const auto& edge : pathEdges) isEdge = isEdge || (edge[0] == path[k] && edge[1] == path[k + 1]);
      if (!isEdge) return false;
    }
    const int* start = kSliceEdgeStart.data() + p * 4;
    const int* end = kSliceEdgeEnd.data() + p * 4;
    if (p % 2 == 0) {
      // P0, P2, P4 walk the paths of kSliceEdgeStart/kSliceEdgeEnd.
      if (path[0] != start[0] || path[1] != end[0] || path[2] != end[1] || path[3] != end[2]) return false;
    } else {
      // P1, P3, P5 share the first edge of the path before and then take their dotted edge.
      if (path[1] != kSlicePaths[size_t(p * 4 - 3)] || path[1] != start[0] || path[2] != end[0]) return false;
    }
  }
  int stripSeen = 0;
  for (int p : kSliceStrip) stripSeen |= 1 << p;
  if (stripSeen != 0x3f || kSliceStrip[0] != 0) return false;
  return true;
}

}  // namespace detail

static_assert(detail::sliceTablesValid(),
              "kSliceSequence rows must be cube rotations with V0 = front, V7 = back, a left-handed (V1, V2, V3) "
              "frame, the edge tables must name path or dotted edges only, kSlicePaths must hold the paths of "
              "P0..P5 as the edge tables walk them, and kSliceStrip a permutation of P0..P5 from P0");

}  // namespace voxbrick::render
