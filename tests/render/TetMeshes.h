// Small tetrahedral meshes built by hand for the mesh tests, and independent ray clips to check them against.
#pragma once

#include <algorithm>
#include <array>
#include <functional>
#include <limits>
#include <vector>

#include <glm/glm.hpp>

#include "mesh/TetMesh.h"

namespace voxbrick::test {

/// A scalar field over world positions.
using Field = std::function<double(const glm::dvec3&)>;

/// Points, tets and the field at each point (rounded to float, as a mesh stores it).
inline mesh::TetMesh makeMesh(const std::vector<glm::dvec3>& points, const std::vector<mesh::Tet>& tets,
                              const Field& field) {
  mesh::TetMesh m;
  for (const glm::dvec3& p : points) {
    m.points.emplace_back(p);
    m.scalars.push_back(float(field(p)));
  }
  m.tets = tets;
  return m;
}

/// The corner tet (0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), moved by `offset`.
inline mesh::TetMesh cornerTet(const Field& field, const glm::dvec3& offset = glm::dvec3(0.0)) {
  return makeMesh({offset, offset + glm::dvec3(1, 0, 0), offset + glm::dvec3(0, 1, 0), offset + glm::dvec3(0, 0, 1)},
                  {{0, 1, 2, 3}}, field);
}

/// The cube [lo, hi]^3 (corner c at bits x, y, z of c) split into 5 tets (a central one and four corners) or into
/// the 6 of Kuhn's triangulation around the diagonal from corner 0 to corner 7. Orientations are mixed on purpose.
inline mesh::TetMesh cube(bool kuhn, const Field& field, double lo = 0, double hi = 1) {
  std::vector<glm::dvec3> points;
  for (int c = 0; c < 8; ++c) points.emplace_back(c & 1 ? hi : lo, c & 2 ? hi : lo, c & 4 ? hi : lo);
  const std::vector<mesh::Tet> kuhnTets = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                                           {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
  return makeMesh(
      points,
      kuhn ? kuhnTets : std::vector<mesh::Tet>{{0, 1, 2, 4}, {3, 2, 1, 7}, {5, 1, 4, 7}, {6, 4, 2, 7}, {1, 2, 4, 7}},
      field);
}

/// n^3 cubes over [lo, hi]^3, each split as Kuhn's (which conforms across cubes).
inline mesh::TetMesh kuhnGrid(int n, double lo, double hi, const Field& field) {
  std::vector<glm::dvec3> points;
  const int m = n + 1;
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) points.push_back(glm::dvec3(lo) + (hi - lo) / n * glm::dvec3(i, j, k));
  std::vector<mesh::Tet> tets;
  const int kuhn[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const auto& t : kuhn) {
          mesh::Tet tet;
          for (int v = 0; v < 4; ++v)
            tet[size_t(v)] = uint32_t((i + (t[v] & 1)) + m * ((j + ((t[v] >> 1) & 1)) + m * (k + ((t[v] >> 2) & 1))));
          tets.push_back(tet);
        }
  return makeMesh(points, tets, field);
}

/// Where the ray o + t d is inside the tet `p` (Cyrus–Beck against its four face planes), independent of the
/// renderer's Plücker tests; false if it misses.
inline bool clipToTet(const std::array<glm::dvec3, 4>& p, const glm::dvec3& o, const glm::dvec3& d, double& t0,
                      double& t1) {
  t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 4; ++i) {
    const glm::dvec3& a = p[size_t((i + 1) % 4)];
    glm::dvec3 n = glm::cross(p[size_t((i + 2) % 4)] - a, p[size_t((i + 3) % 4)] - a);
    if (glm::dot(n, p[size_t(i)] - a) > 0) n = -n;  // outward
    const double num = glm::dot(n, o - a), den = glm::dot(n, d);
    if (den == 0) {
      if (num > 0) return false;
      continue;
    }
    const double t = -num / den;
    if (den < 0)
      t0 = std::max(t0, t);
    else
      t1 = std::min(t1, t);
  }
  return t0 < t1;
}

/// Where the ray o + t d is inside the box [lo, hi] (closed); false if it misses.
inline bool clipToBox(const glm::dvec3& lo, const glm::dvec3& hi, const glm::dvec3& o, const glm::dvec3& d, double& t0,
                      double& t1) {
  t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < lo[a] || o[a] > hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta), t1 = std::min(t1, tb);
  }
  return t0 < t1;
}

}  // namespace voxbrick::test
