#include "mesh/TetMesh.h"

#include <algorithm>
#include <limits>

namespace voxbrick::mesh {

std::pair<glm::vec3, glm::vec3> TetMesh::bounds() const {
  glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-std::numeric_limits<float>::infinity());
  for (const glm::vec3& p : points) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  return {lo, hi};
}

std::pair<float, float> TetMesh::scalarRange() const {
  if (scalars.empty()) return {0.0f, 0.0f};
  const auto [lo, hi] = std::minmax_element(scalars.begin(), scalars.end());
  return {*lo, *hi};
}

void EdgeLengths::add(const std::vector<glm::vec3>& points, const Tet& tet) {
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) {
      const double length = glm::length(glm::dvec3(points[tet[a]]) - glm::dvec3(points[tet[b]]));
      sum += length;
      longest = std::max(longest, length);
    }
  edges += 6;
}

}  // namespace voxbrick::mesh
