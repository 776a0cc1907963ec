// The rays through a window's pixels, affine in window position: exact ownership of the grid renderer's passes and the
// mesh renderer's entry pass start from them.
#pragma once

#include <glm/glm.hpp>

namespace voxbrick::render {

/// The ray through window position (x, y), from the near plane (clip depth -1) to the far plane (+1): both points
/// are affine in window coordinates, since the inverse projection's w does not depend on x and y.
struct PixelRays {
  glm::dvec3 origin, originDx, originDy;
  glm::dvec3 direction, directionDx, directionDy;
};

/// The pixel rays of a `width` x `height` window under `viewProj` (world to clip).
PixelRays pixelRays(const glm::dmat4& viewProj, int width, int height);

}  // namespace voxbrick::render
