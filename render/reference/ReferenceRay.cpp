// Clipping a ray to a box with the GPU's half-open rule.
#include "render/reference/ReferenceRay.h"

#include <algorithm>
#include <limits>
#include <utility>

namespace voxbrick::render::reference {

/// The ray parameters where a ray is inside an axis-aligned box; false if it misses. A ray in the plane of a face
/// belongs to the box on its low face and not on its high one: the GPU's half-open rule, so that the two agree on
/// the pixel centres that views along an axis put exactly on a face.
bool clipToBox(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& lo, const glm::dvec3& hi, double& t0,
               double& t1) {
  t0 = -std::numeric_limits<double>::infinity();
  t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < lo[a] || o[a] >= hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 < t1;
}

}  // namespace voxbrick::render::reference
