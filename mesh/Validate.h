// Checks and repairs a mesh after ingest, so that everything downstream (topology, visibility sorting, the
// renderers) may assume valid indices, finite values and positively oriented, non-degenerate tetrahedra.
#pragma once

#include <cstddef>

#include "mesh/TetMesh.h"

namespace voxbrick::mesh {

/// What validateMesh changed.
struct MeshRepairs {
  size_t flipped = 0;               ///< inverted tets made positive by swapping their last two indices
  size_t removedDegenerate = 0;     ///< tets removed: a repeated index, or |volume| below the threshold
  size_t unreferencedVertices = 0;  ///< vertices no remaining tet uses (kept, not an error)
  bool operator==(const MeshRepairs&) const = default;
};

/// A tet is degenerate when |volume| <= kDegenerateVolume * L^3, L the largest extent of the mesh's bounds.
inline constexpr double kDegenerateVolume = 1e-12;

/// Six times the signed volume of `tet`, (v1 - v0) x (v2 - v0) . (v3 - v0), computed in double. Indices must be valid.
double orientedVolume6(const TetMesh& mesh, const Tet& tet);

/// Validates `mesh` in place: throws MeshError naming the tet for an index out of range, naming the vertex for a
/// NaN or infinite position or scalar, when there is not one scalar per vertex, and when no tet remains. Flips
/// inverted tets and removes degenerate ones (keeping the order of the others). Afterwards every tet satisfies
/// orientedVolume6 > 0.
MeshRepairs validateMesh(TetMesh& mesh);

}  // namespace voxbrick::mesh
