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

}  // namespace voxbrick::mesh
