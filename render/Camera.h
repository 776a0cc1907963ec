// The camera of the optical model: world boxes, the orbit shorthand, view/projection matrices, clip range, frustum.
#pragma once

#include <glm/glm.hpp>

#include "brickstore/Types.h"

namespace voxbrick::render {

/// An axis-aligned box in world units, min <= max per axis.
struct Box {
  glm::dvec3 min{0.0}, max{0.0};

  glm::dvec3 center() const { return 0.5 * (min + max); }
  glm::dvec3 extent() const { return max - min; }
  /// Half the diagonal: the radius of the bounding sphere around center().
  double radius() const { return 0.5 * glm::length(max - min); }
};

/// The world box of a volume of `dims` samples with `spacing`: extent dims*spacing centred on the origin
/// (ARCHITECTURE.md, placement). Throws RenderInputError for dims <= 0 or a spacing that is not finite and positive.
Box volumeBox(const store::Vec3i& dims, const store::Vec3d& spacing);

/// A pinhole (or orthographic) camera in world space, right-handed, GL conventions: the view looks down -Z of eye
/// space, clip-space depth is [-1, 1].
///
/// Up: the basis uses `up` projected onto the plane perpendicular to the view direction. When nothing is left of it
/// (`up` zero or parallel to the view direction, as for orbit() at elevation +-90), the camera uses
/// normalize(cross(+X, viewDirection)) instead, or normalize(cross(+Y, viewDirection)) if the view is nearly along X
/// (|viewDirection.x| >= 0.9). For an orbit at azimuth 0 this is the limit as the elevation approaches +-90 (looking
/// down from +Y, screen-up is -Z; looking up from -Y, it is +Z). "Nothing left" means less than 1e-9 of unit length.
struct Camera {
  glm::dvec3 eye{0.0, 0.0, 1.0};
  glm::dvec3 center{0.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  double fovYDegrees = 30;     ///< vertical field of view, in (0, 179]; also sizes the orthographic view
  bool orthographic = false;

  /// eye = box centre + distanceInRadii * R * (cos el * sin az, sin el, cos el * cos az), R = box.radius(), looking
  /// at the box centre with up +Y (az 0, el 0 puts the eye on +Z; az 90 on +X; el 90 on +Y). Throws
  /// RenderInputError for non-finite angles, distanceInRadii not finite and > 0, or a box without finite size.
  static Camera orbit(double azimuthDeg, double elevationDeg, double distanceInRadii, const Box& box);

  /// Throws RenderInputError (naming the value) for non-finite eye/center/up, eye == center, fov outside (0, 179].
  void validate() const;
  /// Unit vector from eye towards center; validates first.
  glm::dvec3 viewDirection() const;
  /// The unit up vector of the basis actually used: orthogonal to viewDirection(), with the fallback above.
  glm::dvec3 upVector() const;
  /// |center - eye|.
  double distance() const { return glm::length(center - eye); }
  /// World to eye space (lookAt with upVector()); validates first.
  glm::dmat4 view() const;
  /// Eye to clip space. Perspective: vertical fov, `aspect` = width / height. Orthographic: a view of height
  /// 2 * distance() * tan(fov / 2), i.e. what the perspective camera sees in the plane through `center`, and width
  /// height * aspect. Throws RenderInputError unless aspect > 0 and 0 < near < far, all finite.
  glm::dmat4 projection(double aspect, double near, double far) const;
  /// Near and far plane distances that enclose every point of `box` in front of the eye, with a little margin. near
  /// is never below 1e-4 * box.radius() (so the eye may be inside the box; the near plane then cuts it), far - near
  /// is at least 1e-3 * far so that single-precision depth stays usable for a very distant camera, and a box behind
  /// the eye gives a valid but empty range. Throws RenderInputError for a box without finite, positive size.
  void clipRange(const Box& box, double& near, double& far) const;
};

/// The reference renderers' pixel rays (ReferenceRenderer, TetReference): the camera's orthonormal basis and the
/// frame's constants, so that both cast exactly the same rays.
struct RayBasis {
  glm::dvec3 eye{0.0}, forward{0.0, 0.0, -1.0}, right{1.0, 0.0, 0.0}, up{0.0, 1.0, 0.0};
  bool orthographic = false;
  double tanHalfFov = 0, halfHeight = 0, aspect = 1;
  double nearPlane = 0;  ///< distance of the near plane from the eye, along the view axis

  /// The basis of `camera` (right = forward x up, up re-orthogonalised) for an image of `aspect` = width / height,
  /// with the near plane at `nearPlane`.
  static RayBasis of(const Camera& camera, double aspect, double nearPlane);

  /// The ray through the centre of pixel (x, y) of a width x height image (row 0 at the top): origin (the eye, or
  /// for an orthographic view the pixel's point in the eye's plane), unit direction, and the distance along it to
  /// the near plane (perpendicular to the view axis, so an oblique ray meets it further out).
  void pixelRay(int x, int y, int width, int height, glm::dvec3& origin, glm::dvec3& direction, double& tNear) const;
};

/// The six planes of a view volume, each (a, b, c, d) with a point p inside when a*p.x + b*p.y + c*p.z + d >= 0,
/// normalised so that (a, b, c) is a unit vector. Order: left, right, bottom, top, near, far. The default frustum
/// (0, 0, 0, 1) x 6 contains everything.
struct Frustum {
  glm::dvec4 planes[6] = {{0, 0, 0, 1}, {0, 0, 0, 1}, {0, 0, 0, 1}, {0, 0, 0, 1}, {0, 0, 0, 1}, {0, 0, 0, 1}};

  /// Extracts the planes from projection * view (GL clip space, -w <= x, y, z <= w).
  static Frustum fromMatrix(const glm::dmat4& viewProjection);
  /// Conservative: false only if the box lies entirely outside one plane (a box that misses the frustum only near
  /// a corner may still report true).
  bool intersects(const Box& box) const;
};

}  // namespace voxbrick::render
