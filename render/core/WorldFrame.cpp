// The volume's world frame: placement of the local box in the world, and the mirror of reflected frames.
#include "render/core/WorldFrame.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

WorldFrame WorldFrame::of(const store::Orientation& orientation, const store::Vec3i& dims,
                          const store::Vec3d& spacing) {
  WorldFrame f;
  // The default orientation says nothing about where the volume lies (raw, synthetic, OpenVDB, a NIfTI without
  // qform and sform): its world is its local frame, the box centred on the origin, as before orientations.
  if (orientation == store::Orientation{}) return f;
  for (int a = 0; a < 3; ++a)
    f.rotation[a] = glm::dvec3(orientation.axes[a][0], orientation.axes[a][1], orientation.axes[a][2]);
  const glm::dmat3 gram = glm::transpose(f.rotation) * f.rotation;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      if (!(std::abs(gram[a][b] - (a == b ? 1.0 : 0.0)) <= 1e-6))
        throw RenderInputError("WorldFrame: the orientation's axes are not orthonormal (axes " + std::to_string(a) +
                               " and " + std::to_string(b) + " have dot product " + numberText(gram[a][b]) + ")");
  const glm::dvec3 origin(orientation.origin[0], orientation.origin[1], orientation.origin[2]);
  const glm::dvec3 halfSpan(0.5 * double(dims.x - 1) * spacing.x, 0.5 * double(dims.y - 1) * spacing.y,
                            0.5 * double(dims.z - 1) * spacing.z);
  f.center = origin + f.rotation * halfSpan;
  f.patient = orientation.patient;
  return f;
}

bool WorldFrame::mirrored() const { return glm::determinant(rotation) < 0; }

void flipHorizontally(image::ImageF& image) {
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width / 2; ++x)
      std::swap_ranges(image.pixel(x, y), image.pixel(x, y) + 4, image.pixel(image.width - 1 - x, y));
}

void flipHorizontally(image::Image8& image) {
  uint8_t* rows = image.rgba.data();
  for (int y = 0; y < image.height; ++y, rows += size_t(image.width) * 4)
    for (int x = 0; x < image.width / 2; ++x)
      std::swap_ranges(rows + 4 * x, rows + 4 * x + 4, rows + 4 * (image.width - 1 - x));
}

void finishImage(const WorldFrame& frame, image::ImageF& image) {
  if (frame.mirrored()) flipHorizontally(image);
}

void finishImage(const WorldFrame& frame, image::Image8& image) {
  if (frame.mirrored()) flipHorizontally(image);
}

}  // namespace voxbrick::render
