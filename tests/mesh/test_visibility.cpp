// Visibility orders: every order is a permutation of the tets; on convex meshes MPVO's order puts, across every
// interior face, the tet on the eye's side first, from any eye (outside, inside, orthographic), without cycles.
#include <gtest/gtest.h>

#include <algorithm>

#include "mesh/SyntheticMesh.h"
#include "mesh/Topology.h"
#include "mesh/Visibility.h"

namespace voxbrick::mesh {
namespace {

/// Whether tet `t` is on the eye's side of its face `f` (the side its neighbour across f is not on), computed in
/// double from the face's plane, independently of Visibility.cpp's own test.
bool eyeSide(const TetMesh& m, uint32_t t, int f, const ViewPoint& view, double& margin) {
  const Tet& tet = m.tets[t];
  const glm::dvec3 a(m.points[tet[(f + 1) & 3]]), b(m.points[tet[(f + 2) & 3]]), c(m.points[tet[(f + 3) & 3]]);
  glm::dvec3 n = glm::cross(b - a, c - a);
  if (glm::dot(n, glm::dvec3(m.points[tet[f]]) - a) < 0) n = -n;  // towards t
  const double s = view.orthographic ? -glm::dot(n, view.direction) : glm::dot(n, view.eye - a);
  margin = std::abs(s) / glm::length(n);
  return s > 0;
}

void expectPermutation(const std::vector<uint32_t>& order, size_t n) {
  std::vector<uint32_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  ASSERT_EQ(sorted.size(), n);
  for (size_t i = 0; i < n; ++i) ASSERT_EQ(sorted[i], i);
}

TEST(Visibility, MpvoOrdersEveryInteriorFaceOnConvexMeshes) {
  const TetMesh m = syntheticMesh("box,n=6");
  const Topology topo = buildTopology(m);
  std::vector<ViewPoint> views = {
      {{3.1, 2.3, 4.7}, {0, 0, -1}, false},                             // outside, perspective
      {{0.13, -0.21, 0.07}, {0, 0, -1}, false},                         // inside the mesh
      {{0, 0, 0}, glm::normalize(glm::dvec3(-0.3, -0.5, -0.8)), true},  // orthographic, oblique
      {{0, 0, 0}, {0, 0, -1}, true},                                    // orthographic along an axis: faces edge on
  };
  for (size_t v = 0; v < views.size(); ++v) {
    std::vector<uint32_t> order;
    VisibilityStats stats;
    mpvoOrder(m, topo, views[v], order, &stats);
    expectPermutation(order, m.tets.size());
    EXPECT_EQ(stats.cyclesBroken, 0u) << "view " << v;
    EXPECT_GT(stats.sources, 0u);
    std::vector<size_t> position(m.tets.size());
    for (size_t i = 0; i < order.size(); ++i) position[order[i]] = i;
    size_t checked = 0, wrong = 0;
    for (uint32_t t = 0; t < m.tets.size(); ++t)
      for (int f = 0; f < 4; ++f) {
        const int32_t other = topo.neighbours[t][f];
        if (other == Topology::kBoundary) continue;
        double margin = 0;
        const bool front = eyeSide(m, t, f, views[v], margin);
        if (margin < 1e-9) continue;  // seen edge on: either order is right
        ++checked;
        if (front != (position[t] < position[size_t(other)])) ++wrong;
      }
    EXPECT_GT(checked, m.tets.size()) << "view " << v;
    EXPECT_EQ(wrong, 0u) << "view " << v << ": faces whose tets are out of order";
  }
}

TEST(Visibility, CentroidOrderIsNearestFirst) {
  const TetMesh m = syntheticMesh("ball,n=8");
  const ViewPoint view{{0.5, 2.0, 3.0}, {0, 0, -1}, false};
  std::vector<uint32_t> order;
  centroidOrder(m, view, order);
  expectPermutation(order, m.tets.size());
  auto depth = [&](uint32_t t) {
    glm::dvec3 c(0.0);
    for (uint32_t v : m.tets[t]) c += glm::dvec3(m.points[v]);
    return glm::length(0.25 * c - view.eye);
  };
  for (size_t i = 1; i < order.size(); ++i) ASSERT_LE(depth(order[i - 1]), depth(order[i]) + 1e-12) << i;
}

}  // namespace
}  // namespace voxbrick::mesh
