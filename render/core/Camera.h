// The camera of the optical model: world boxes, the orbit shorthand, view/projection matrices, clip range, frustum.
#pragma once

#include <span>
#include <string>

#include <glm/glm.hpp>

#include "brickstore/format/Types.h"
#include "common/EnumNames.h"

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

/// The pole of an orbit (CameraSpec::upAxis, `--up-axis`): a world axis.
enum class UpAxis { PosX, NegX, PosY, NegY, PosZ, NegZ };

/// "+x", "-x", "+y", "-y", "+z", "-z"; and "x", "y", "z" for the positive ones, which parseUpAxis takes too.
inline constexpr common::EnumName<UpAxis> kUpAxisNames[] = {
    {UpAxis::PosX, "+x"}, {UpAxis::NegX, "-x"}, {UpAxis::PosY, "+y"}, {UpAxis::NegY, "-y"}, {UpAxis::PosZ, "+z"},
    {UpAxis::NegZ, "-z"}, {UpAxis::PosX, "x"},  {UpAxis::PosY, "y"},  {UpAxis::PosZ, "z"}};
constexpr std::span<const common::EnumName<UpAxis>> enumNames(UpAxis) { return kUpAxisNames; }
inline const char* upAxisName(UpAxis axis) { return common::nameOf(axis); }
/// The up axis named "+x", "-x", "+y", "-y", "+z" or "-z" ("x" = "+x"); throws RenderInputError naming `what` and
/// the valid names otherwise.
UpAxis parseUpAxis(const std::string& name, const std::string& what);

/// The axes of an orbit: `up` (the pole), `front` (where the eye is at azimuth 0, elevation 0) and `side` = up x
/// front (where the eye is at azimuth 90, elevation 0). For each up axis (of):
///
/// | up axis | front (az 0) | side (az 90) | for patient data (RAS)                                            |
/// | ------- | ------------ | ------------ | ----------------------------------------------------------------- |
/// | +z      | +y           | -x           | superior up; az 0 anterior view, az 90 the patient's left, 180 posterior |
/// | -z      | +y           | +x           |                                                                   |
/// | +y      | +z           | +x           | the Y-up orbit, Camera::orbit's default                           |
/// | -y      | +z           | -x           |                                                                   |
/// | +x      | +z           | -y           |                                                                   |
/// | -x      | +z           | +y           |                                                                   |
struct OrbitAxes {
  glm::dvec3 up{0, 1, 0}, front{0, 0, 1}, side{1, 0, 0};

  /// The axes of the table above.
  static OrbitAxes of(UpAxis axis);
  /// of(parseUpAxis(name, what)).
  static OrbitAxes ofUpAxis(const std::string& name, const std::string& what) { return of(parseUpAxis(name, what)); }
  /// The unit direction from the orbit's centre to its eye at (azimuth, elevation) degrees: cos el * (cos az * front +
  /// sin az * side) + sin el * up (Camera::orbitAt).
  glm::dvec3 eyeDirection(double azimuthDeg, double elevationDeg) const;
};

/// A pinhole (or orthographic) camera in world space, right-handed, GL conventions: the view looks down -Z of eye
/// space, clip-space depth is [-1, 1].
///
/// Up: the basis uses `up` projected onto the plane perpendicular to the view direction. When nothing is left of it
/// (`up` zero or parallel to the view direction), the camera uses normalize(cross(+X, viewDirection)) instead, or
/// normalize(cross(+Y, viewDirection)) if the view is nearly along X (|viewDirection.x| >= 0.9). "Nothing left"
/// means less than 1e-9 of unit length. orbit() never needs the fallback: its up is exact at every elevation.
struct Camera {
  glm::dvec3 eye{0.0, 0.0, 1.0};
  glm::dvec3 center{0.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  double fovYDegrees = 30;  ///< vertical field of view, in (0, 179]; also sizes the orthographic view
  bool orthographic = false;

  /// The eye at `distance` (world units) from the box centre in the direction cos el * (cos az * front + sin az *
  /// side) + sin el * up, looking at the box centre. Screen-up is the derivative of that direction by the elevation,
  /// -sin el * (cos az * front + sin az * side) + cos el * up (`up` holds `axes.up`, negated past the pole, where
  /// that projects to the same direction, and the derivative within 1e-6 rad of the pole): continuous through el = +-90
  /// (at el 90 and az 0 it is -front, the old Y-up orbit's limit), so an orbit dragged over the pole turns the image
  /// smoothly instead of flipping it. Throws RenderInputError for non-finite angles, a distance not finite and > 0,
  /// or a box without finite size.
  static Camera orbitAt(double azimuthDeg, double elevationDeg, double distance, const Box& box, const OrbitAxes& axes);
  /// orbitAt with the distance in bounding-sphere radii (box.radius()) and the Y-up axes (up +y, az 0 on +z, az 90
  /// on +x, el 90 on +y) unless others are given.
  static Camera orbit(double azimuthDeg, double elevationDeg, double distanceInRadii, const Box& box,
                      const OrbitAxes& axes = {});
  /// The distance from a sphere's centre at which a camera aimed at it sees all of it: radius / sin(half the smaller
  /// of the vertical and horizontal fov) for a perspective camera, so that the sphere's silhouette touches the
  /// frame at most; for an orthographic one the distance whose view (2 * distance * tan(fov / 2) tall, `aspect` as
  /// wide) spans the sphere's diameter, and never inside the sphere. Both with a margin of kFitMargin. Throws
  /// RenderInputError for a radius, fov or aspect out of range.
  static double fitDistance(double radius, double fovYDegrees, double aspect, bool orthographic);
  /// The fit's margin: the sphere fills at most 1 / kFitMargin of the frame's smaller side.
  static constexpr double kFitMargin = 1.05;

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
