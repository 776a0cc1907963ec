// A tetrahedral mesh's tets ready to draw (the whole mesh, or the part a frame needs) and the constants every frame of
// it uses whatever part is drawn (world box, default reference length, value range). GL-free.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "mesh/TetMesh.h"
#include "mesh/Topology.h"
#include "render/core/Camera.h"

namespace voxbrick::render {

/// What every frame of a mesh uses, whatever part of it is drawn: all of the whole mesh, so that a frame drawn from
/// part of the tets equals one drawn from all of them.
struct TetMeshConstants {
  Box bounds;  ///< the points' box, world units (the camera orbits its centre; vertices are centred on it)
  double meanEdgeLength = 1;  ///< over every tet's six edges: the default reference length (a "cell")
  double longestEdge = 1;     ///< the longest segment a ray can have in one tet
  float scalarMin = 0, scalarMax = 0;
  uint64_t tetCount = 0, pointCount = 0;
  std::string field;
};

/// Tets ready to draw: the whole mesh, or the part of it a frame needs (a paged mesh's working set), with the whole
/// mesh's constants. Built once, shared read-only.
struct TetMeshData : TetMeshConstants {
  mesh::TetMesh mesh;
  mesh::Topology topology;
  /// Per tet, the smallest and largest of its four scalars: the values inside it (linear) lie between, so a tet the
  /// transfer function makes transparent over that range adds nothing and is not drawn.
  std::vector<std::pair<float, float>> tetRanges;
  /// Different for every TetMeshData made in this process: a renderer that uploaded one knows it again by this.
  uint64_t id = 0;

  /// The whole of `mesh` (which must hold at least one tet with valid indices): the constants derived from it.
  TetMeshData(mesh::TetMesh mesh, mesh::Topology topology);
  /// Part of a larger mesh, `whole` its constants. The topology's boundary faces are the part's own: faces of the
  /// whole's boundary, and faces whose neighbour is not in the part.
  TetMeshData(mesh::TetMesh mesh, mesh::Topology topology, const TetMeshConstants& whole);

  /// The host bytes a mesh of these counts takes held whole: points and scalars (16 a point), tets, neighbours and
  /// value ranges (40 a tet), boundary faces (8 each).
  static size_t hostBytes(uint64_t tets, uint64_t points, uint64_t boundaryFaces);
};

/// Throws RenderInputError when `constants`' tets have no size (a mean edge length that is not positive and finite).
void checkEdgeLengths(const TetMeshConstants& constants);

}  // namespace voxbrick::render
