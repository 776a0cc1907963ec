// One pixel's ray through the volume's box, as the reference renderer integrates it.
#pragma once

#include <glm/glm.hpp>

namespace voxbrick::render::reference {

/// The time from the near plane to the box's exit for one pixel: origin, unit direction, interval.
struct Ray {
  glm::dvec3 origin, dir;
  double t0 = 0, t1 = 0;
};

/// The ray parameters where a ray is inside an axis-aligned box; false if it misses. A ray in the plane of a face
/// belongs to the box on its low face and not on its high one: the GPU's half-open rule, so that the two agree on
/// the pixel centres that views along an axis put exactly on a face.
bool clipToBox(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& lo, const glm::dvec3& hi, double& t0,
               double& t1);

}  // namespace voxbrick::render::reference
