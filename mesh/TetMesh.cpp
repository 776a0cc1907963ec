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

std::vector<uint32_t> keepUsedPoints(TetMesh& part, const std::vector<glm::vec3>& points,
                                     const std::vector<float>& scalars) {
  std::vector<uint32_t> newIndex(points.size(), kNotKept);
  for (const Tet& tet : part.tets)
    for (const uint32_t v : tet) newIndex[v] = 0;
  uint32_t used = 0;
  for (uint32_t& n : newIndex)
    if (n != kNotKept) n = used++;
  part.points.resize(used);
  part.scalars.resize(used);
  for (size_t v = 0; v < points.size(); ++v)
    if (newIndex[v] != kNotKept) {
      part.points[newIndex[v]] = points[v];
      part.scalars[newIndex[v]] = scalars[v];
    }
  return newIndex;
}

}  // namespace voxbrick::mesh
