// The world frame of a volume: where its local box (centred on the origin, ARCHITECTURE.md placement) lies in the
// world (RAS for patient data), so that cameras are given in world coordinates whatever the acquisition's axes.
#pragma once

#include <glm/glm.hpp>

#include "brickstore/format/Orientation.h"
#include "brickstore/format/Types.h"
#include "image/Image.h"

namespace voxbrick::render {

/// world = rotation * local + center. `rotation`'s columns are the world directions of the local x, y, z axes (the
/// index axes i, j, k); it is orthonormal with determinant +1 or -1 (a mirrored acquisition). The renderers draw in
/// the local frame: a world camera is moved into it (toLocal), and when the frame is mirrored the image drawn by the
/// proper camera is flipped left to right (finishImage), since no right-handed camera sees a mirrored world.
struct WorldFrame {
  glm::dmat3 rotation{1.0};
  glm::dvec3 center{0.0};
  bool patient = false;  ///< the input stated a patient frame (views and the default up mean anatomy)

  /// The frame of a volume of `dims` samples with `spacing` and `orientation`: center = origin + R * ((dims - 1) / 2
  /// * spacing), the world position of the local box's centre. The default orientation (identity axes, origin 0,
  /// no patient frame: nothing stated) gives the identity frame, so such data keep the box centred on the world's
  /// origin. Throws RenderInputError for axes that are not orthonormal (within 1e-6).
  static WorldFrame of(const store::Orientation& orientation, const store::Vec3i& dims, const store::Vec3d& spacing);

  /// True when det(rotation) < 0.
  bool mirrored() const;
  glm::dvec3 pointToWorld(const glm::dvec3& local) const { return rotation * local + center; }
  glm::dvec3 pointToLocal(const glm::dvec3& world) const { return glm::transpose(rotation) * (world - center); }
  glm::dvec3 directionToLocal(const glm::dvec3& world) const { return glm::transpose(rotation) * world; }
};

/// What every renderer does last to a frame drawn in `frame`'s local frame: flips it left to right when the frame is
/// mirrored (the GPU renderers through RenderEngine and ReferenceRenderer both call it, so the reference judges the
/// same image); otherwise leaves it alone.
void finishImage(const WorldFrame& frame, image::ImageF& image);
void finishImage(const WorldFrame& frame, image::Image8& image);

/// Flips `image` left to right in place.
void flipHorizontally(image::ImageF& image);
void flipHorizontally(image::Image8& image);

}  // namespace voxbrick::render
