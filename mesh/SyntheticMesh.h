// Synthetic tetrahedral meshes for tests and benchmarks: a cube cut into Kuhn tetrahedra, or the part of it inside
// the unit ball, with an analytic scalar on the vertices.
#pragma once

#include <string>

#include <glm/glm.hpp>

#include "mesh/MeshWriters.h"  // tests and benchmarks that make a mesh usually write it next
#include "mesh/TetMesh.h"

namespace voxbrick::mesh {

/// A mesh from `spec`, "SHAPE[,key=value...]":
///   box   the cube [-1, 1]^3 cut into n^3 cells, each split into 6 tets along its main diagonal (the Kuhn, or
///         Freudenthal, split), so faces match across cells: 6 n^3 tets, (n + 1)^3 vertices;
///   ball  the box's tets whose four vertices lie in the unit ball (a staircase boundary, not convex); unused
///         vertices are dropped.
/// Keys: n (cells per axis, 1..256, default 16), field (blobs, the default, or linear: (x + 1) / 2). Every tet is
/// positively oriented. Throws MeshError naming the spec and the bad key or value, or when no tet remains.
TetMesh syntheticMesh(const std::string& spec);

/// The "blobs" field: 1 - exp(-2.5 s), s a weighted sum of three Gaussians; smooth, in [0, 1) everywhere.
float blobsField(const glm::vec3& p);

}  // namespace voxbrick::mesh
