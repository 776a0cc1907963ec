// The face-adjacency graph of a tetrahedral mesh and its boundary faces: what MPVO visibility sorting walks and what
// the mesh store keeps. No GL.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "mesh/TetMesh.h"

namespace voxbrick::mesh {

/// Face f of a tet is the face opposite its vertex f: the other three vertices.
struct BoundaryFace {
  uint32_t tet = 0;
  uint8_t face = 0;  ///< 0..3: the face opposite vertex `face`
  bool operator==(const BoundaryFace&) const = default;
};

struct Topology {
  static constexpr int32_t kBoundary = -1;
  /// neighbours[t][f]: the tet sharing face f of tet t, or kBoundary.
  std::vector<std::array<int32_t, 4>> neighbours;
  /// Every face with kBoundary, in tet order then face order.
  std::vector<BoundaryFace> boundary;
};

/// The adjacency of `mesh` (indices must be valid). Throws MeshError naming the face's vertices and the tets when a
/// face is shared by more than two tets (a non-manifold mesh).
Topology buildTopology(const TetMesh& mesh);

}  // namespace voxbrick::mesh
