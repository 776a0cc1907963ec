// buildTopology: neighbours across shared faces, boundary faces, non-manifold refusal, and its speed on 1M tets.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>

#include "mesh/SyntheticMesh.h"
#include "mesh/Topology.h"
#include "mesh/Validate.h"

using namespace voxbrick::mesh;

namespace {

std::array<uint32_t, 3> faceVertices(const Tet& tet, int face) {
  std::array<uint32_t, 3> v{tet[(face + 1) % 4], tet[(face + 2) % 4], tet[(face + 3) % 4]};
  std::sort(v.begin(), v.end());
  return v;
}

// Every neighbour relation is mutual and across the same three vertices; the boundary lists exactly the faces
// without a neighbour, in tet then face order.
void expectConsistent(const TetMesh& mesh, const Topology& topology) {
  ASSERT_EQ(topology.neighbours.size(), mesh.tets.size());
  std::vector<BoundaryFace> boundary;
  size_t interior = 0;
  for (uint32_t t = 0; t < mesh.tets.size(); ++t)
    for (uint8_t f = 0; f < 4; ++f) {
      const int32_t u = topology.neighbours[t][f];
      if (u == Topology::kBoundary) {
        boundary.push_back({t, f});
        continue;
      }
      ++interior;
      ASSERT_NE(u, static_cast<int32_t>(t));
      int back = -1;
      for (int g = 0; g < 4; ++g)
        if (topology.neighbours[u][g] == static_cast<int32_t>(t)) back = g;
      ASSERT_GE(back, 0) << "tet " << t << " face " << int(f) << " is not matched back";
      ASSERT_EQ(faceVertices(mesh.tets[t], f), faceVertices(mesh.tets[u], back));
    }
  EXPECT_EQ(topology.boundary, boundary);
  EXPECT_EQ(interior % 2, 0u);
}

TEST(Topology, TwoTetsShareOneFace) {
  TetMesh mesh;
  mesh.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  mesh.tets = {{0, 1, 2, 3}, {4, 3, 2, 1}};
  const Topology topology = buildTopology(mesh);
  // Tet 0's face 0 (opposite vertex 0) is {1, 2, 3}; so is tet 1's face 0 (opposite vertex 4).
  EXPECT_EQ(topology.neighbours[0], (std::array<int32_t, 4>{1, -1, -1, -1}));
  EXPECT_EQ(topology.neighbours[1], (std::array<int32_t, 4>{0, -1, -1, -1}));
  EXPECT_EQ(topology.boundary, (std::vector<BoundaryFace>{{0, 1}, {0, 2}, {0, 3}, {1, 1}, {1, 2}, {1, 3}}));
  expectConsistent(mesh, topology);
}

TEST(Topology, KuhnBoxFacesMatchAcrossCells) {
  for (int n : {1, 2, 3}) {
    const TetMesh mesh = syntheticMesh("box,n=" + std::to_string(n));
    const Topology topology = buildTopology(mesh);
    expectConsistent(mesh, topology);
    // Each of the cube's 6 faces is n^2 squares of 2 triangles.
    EXPECT_EQ(topology.boundary.size(), static_cast<size_t>(12 * n * n)) << n;
  }
}

TEST(Topology, BallBoundaryIsClosed) {
  const TetMesh mesh = syntheticMesh("ball,n=10");
  const Topology topology = buildTopology(mesh);
  expectConsistent(mesh, topology);
  // A closed surface: every boundary edge is on an even number of boundary triangles (2, or 4 where the
  // staircase touches itself along an edge).
  std::map<std::pair<uint32_t, uint32_t>, int> edges;
  for (const BoundaryFace& face : topology.boundary) {
    const auto v = faceVertices(mesh.tets[face.tet], face.face);  // ascending
    ++edges[{v[0], v[1]}];
    ++edges[{v[1], v[2]}];
    ++edges[{v[0], v[2]}];
  }
  ASSERT_FALSE(edges.empty());
  for (const auto& [edge, count] : edges) EXPECT_EQ(count % 2, 0) << edge.first << "-" << edge.second;
}

TEST(Topology, ThreeTetsOnOneFaceAreRefused) {
  TetMesh mesh;
  mesh.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, -1}, {1, 1, 1}};
  mesh.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}, {5, 0, 1, 2}};
  try {
    buildTopology(mesh);
    FAIL() << "a non-manifold face was accepted";
  } catch (const MeshError& e) {
    EXPECT_STREQ(e.what(),
                 "buildTopology: the face of vertices 0, 1, 2 is shared by 3 tets (0, 1, 2): the mesh is "
                 "not manifold");
  }
}

TEST(Topology, OneMillionTets) {
  TetMesh mesh = syntheticMesh("box,n=56");  // 6 * 56^3 = 1,053,696 tets
  ASSERT_EQ(mesh.tets.size(), 1053696u);
  const auto start = std::chrono::steady_clock::now();
  const Topology topology = buildTopology(mesh);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("buildTopology: %zu tets, %zu vertices in %.3f s\n", mesh.tets.size(), mesh.points.size(), seconds);
  RecordProperty("seconds", std::to_string(seconds));
  EXPECT_EQ(topology.boundary.size(), 12u * 56 * 56);
  EXPECT_LT(seconds, 10.0);  // a generous bound for slow CI machines; the README states the measured time
}

}  // namespace
