// Pixel rays by unprojecting a window's corners.
#include "render/core/PixelRays.h"

namespace voxbrick::render {

PixelRays pixelRays(const glm::dmat4& viewProj, int width, int height) {
  const glm::dmat4 inverseViewProj = glm::inverse(viewProj);
  auto unproject = [&](double wx, double wy, double depth) {
    const glm::dvec4 h = inverseViewProj * glm::dvec4(2 * wx / width - 1, 2 * wy / height - 1, depth, 1);
    return glm::dvec3(h) / h.w;
  };
  const glm::dvec3 near0 = unproject(0, 0, -1), far0 = unproject(0, 0, 1);
  const glm::dvec3 nearX = unproject(1, 0, -1), nearY = unproject(0, 1, -1);
  PixelRays r;
  r.origin = near0;
  r.originDx = nearX - near0;
  r.originDy = nearY - near0;
  r.direction = far0 - near0;
  r.directionDx = (unproject(1, 0, 1) - nearX) - (far0 - near0);
  r.directionDy = (unproject(0, 1, 1) - nearY) - (far0 - near0);
  return r;
}

}  // namespace voxbrick::render
