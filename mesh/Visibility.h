// Visibility order of a tetrahedral mesh's cells for front-to-back compositing (Carrard & Juliachs): MPVO over the
// face-adjacency graph, and a centroid sort to compare it with. No GL.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "mesh/TetMesh.h"
#include "mesh/Topology.h"

namespace voxbrick::mesh {

/// Where the cells are seen from: a perspective eye, or an orthographic view along `direction` (unit, from the eye
/// into the scene).
struct ViewPoint {
  glm::dvec3 eye{0.0};
  glm::dvec3 direction{0.0, 0.0, -1.0};
  bool orthographic = false;
};

struct VisibilityStats {
  size_t sources = 0;       ///< MPVO: cells no neighbour hides, where the walk starts
  size_t cyclesBroken = 0;  ///< MPVO: times no cell was free to go next (a cycle of the "in front of" relation)
  double ms = 0;
};

/// Every tet index once, nearest centroid first (the distance from the eye, or along `direction` when orthographic).
/// Multithreaded.
void centroidOrder(const TetMesh& mesh, const ViewPoint& view, std::vector<uint32_t>& order,
                   VisibilityStats* stats = nullptr);

/// Every tet index once, front to back by MPVO (Williams 1992): across each interior face, the tet on the eye's side
/// goes first; a tet goes once every neighbour in front of it has. The free tets (all of whose front neighbours have
/// gone) are taken nearest centroid first rather than first come (what MPVONC-style variants do for non-convex
/// meshes, whose gaps hide cells from one another without a shared face); a cycle is broken by taking the nearest
/// tet not yet placed. Exact for convex meshes without cycles. The "in front" test of a face is computed the same
/// way from both of its tets (from its vertices in index order), so the two sides never disagree. The per-face
/// tests run multithreaded; the walk is sequential.
void mpvoOrder(const TetMesh& mesh, const Topology& topology, const ViewPoint& view, std::vector<uint32_t>& order,
               VisibilityStats* stats = nullptr);

}  // namespace voxbrick::mesh
