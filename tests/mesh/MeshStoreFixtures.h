// Small meshes for the mesh store's tests, with their topology made here (not by buildTopology, which these tests do
// not depend on): a cube of five tets whose adjacency is written out by hand, and a grid of Kuhn-split cubes matched
// by a naive sort of faces.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <tuple>
#include <vector>

#include "mesh/TetMesh.h"
#include "mesh/Topology.h"

namespace voxbrick::mesh::test {

/// The unit cube as a central tet and four corner tets. Corner c is (c & 1, c >> 1 & 1, c >> 2 & 1).
inline TetMesh handCube() {
  TetMesh m;
  for (int c = 0; c < 8; ++c) m.points.emplace_back(float(c & 1), float(c >> 1 & 1), float(c >> 2 & 1));
  m.tets = {{0, 1, 2, 4}, {3, 1, 2, 7}, {5, 1, 4, 7}, {6, 2, 4, 7}, {1, 2, 4, 7}};
  m.scalars = {0.0f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, -7.5f};
  m.field = "corner";
  return m;
}

/// handCube's adjacency: each corner tet meets the centre across the face opposite its corner (face 0); the
/// centre's face f is opposite its vertex f, which the corner tet 3 - f does not hold.
inline Topology handCubeTopology() {
  Topology t;
  const int32_t B = Topology::kBoundary;
  t.neighbours = {{4, B, B, B}, {4, B, B, B}, {4, B, B, B}, {4, B, B, B}, {3, 2, 1, 0}};
  for (uint32_t tet = 0; tet < 4; ++tet)
    for (uint8_t f = 1; f < 4; ++f) t.boundary.push_back({tet, f});
  return t;
}

/// The three vertices of face f of tet t (the face opposite vertex f), sorted.
inline std::array<uint32_t, 3> faceOf(const Tet& t, int f) {
  std::array<uint32_t, 3> v{};
  for (int i = 0, k = 0; i < 4; ++i)
    if (i != f) v[size_t(k++)] = t[size_t(i)];
  std::sort(v.begin(), v.end());
  return v;
}

/// The face-adjacency of `mesh` by sorting every face: O(n log n), enough for tests.
inline Topology matchFaces(const TetMesh& mesh) {
  std::vector<std::tuple<std::array<uint32_t, 3>, uint32_t, int>> faces;
  for (uint32_t t = 0; t < mesh.tets.size(); ++t)
    for (int f = 0; f < 4; ++f) faces.emplace_back(faceOf(mesh.tets[t], f), t, f);
  std::sort(faces.begin(), faces.end());
  Topology topo;
  topo.neighbours.assign(mesh.tets.size(),
                         {Topology::kBoundary, Topology::kBoundary, Topology::kBoundary, Topology::kBoundary});
  for (size_t i = 0; i + 1 < faces.size(); ++i)
    if (std::get<0>(faces[i]) == std::get<0>(faces[i + 1])) {
      const auto [fa, ta, a] = faces[i];
      const auto [fb, tb, b] = faces[i + 1];
      topo.neighbours[ta][size_t(a)] = int32_t(tb);
      topo.neighbours[tb][size_t(b)] = int32_t(ta);
    }
  for (uint32_t t = 0; t < mesh.tets.size(); ++t)
    for (uint8_t f = 0; f < 4; ++f)
      if (topo.neighbours[t][f] == Topology::kBoundary) topo.boundary.push_back({t, f});
  return topo;
}

/// nx x ny x nz unit cubes from the origin, each cut into the six Kuhn tets along its main diagonal (the same
/// diagonal everywhere, so the faces of neighbouring cubes match), positively oriented; scalar x^2 - y + z / 2.
inline TetMesh kuhnGrid(int nx, int ny, int nz) {
  TetMesh m;
  auto id = [&](int x, int y, int z) { return uint32_t(x + (nx + 1) * (y + (ny + 1) * z)); };
  for (int z = 0; z <= nz; ++z)
    for (int y = 0; y <= ny; ++y)
      for (int x = 0; x <= nx; ++x) {
        m.points.emplace_back(float(x), float(y), float(z));
        m.scalars.push_back(float(x * x) - float(y) + 0.5f * float(z));
      }
  const std::array<std::array<int, 3>, 6> perms{{{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        for (const auto& p : perms) {
          std::array<int, 3> c{x, y, z};
          Tet t{};
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[size_t(p[size_t(s)])];
            t[size_t(s) + 1] = id(c[0], c[1], c[2]);
          }
          const glm::vec3 a = m.points[t[0]];
          if (glm::dot(glm::cross(m.points[t[1]] - a, m.points[t[2]] - a), m.points[t[3]] - a) < 0)
            std::swap(t[2], t[3]);
          m.tets.push_back(t);
        }
  m.field = "grid";
  return m;
}

/// Neighbours name each other back across the same three vertices, and the boundary list is every open face, in
/// tet then face order.
inline void expectConsistent(const TetMesh& mesh, const Topology& topo) {
  ASSERT_EQ(topo.neighbours.size(), mesh.tets.size());
  std::vector<BoundaryFace> open;
  for (uint32_t t = 0; t < mesh.tets.size(); ++t)
    for (uint8_t f = 0; f < 4; ++f) {
      const int32_t n = topo.neighbours[t][f];
      if (n == Topology::kBoundary) {
        open.push_back({t, f});
        continue;
      }
      ASSERT_GE(n, 0);
      ASSERT_LT(size_t(n), mesh.tets.size());
      const auto& back = topo.neighbours[size_t(n)];
      const auto g = std::find(back.begin(), back.end(), int32_t(t));
      ASSERT_NE(g, back.end()) << "tet " << n << " does not name " << t << " back";
      EXPECT_EQ(faceOf(mesh.tets[t], f), faceOf(mesh.tets[size_t(n)], int(g - back.begin())));
    }
  EXPECT_EQ(topo.boundary, open);
}

}  // namespace voxbrick::mesh::test
