// Camera math with no GL: orbit placement, the view basis, matrices, clip range and frustum planes.
#include "render/core/Camera.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {
namespace {

std::string vecText(const glm::dvec3& v) {
  return "(" + numberText(v.x) + ", " + numberText(v.y) + ", " + numberText(v.z) + ")";
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

void checkBox(const Box& box, const char* function) {
  double r = box.radius();
  if (!finite(box.min) || !finite(box.max) ||
      !(box.min.x <= box.max.x && box.min.y <= box.max.y && box.min.z <= box.max.z) || !(r > 0) || !std::isfinite(r))
    throw RenderInputError(std::string(function) + ": box " + vecText(box.min) + " - " + vecText(box.max) +
                           " is not a finite box of positive size");
}

}  // namespace

Box volumeBox(const store::Vec3i& dims, const store::Vec3d& spacing) {
  glm::dvec3 half;
  for (int a = 0; a < 3; ++a) {
    if (dims[a] <= 0)
      throw RenderInputError("volumeBox: dims[" + std::to_string(a) + "] = " + std::to_string(dims[a]) + " <= 0");
    if (!(spacing[a] > 0) || !std::isfinite(spacing[a]))
      throw RenderInputError("volumeBox: spacing[" + std::to_string(a) + "] = " + numberText(spacing[a]) +
                             " is not finite and positive");
    half[a] = 0.5 * static_cast<double>(dims[a]) * spacing[a];
  }
  return Box{-half, half};
}

UpAxis parseUpAxis(const std::string& name, const std::string& what) {
  if (const std::optional<UpAxis> axis = common::valueOf<UpAxis>(name)) return *axis;
  throw RenderInputError(what + ": unknown up axis '" + name + "' (one of " +
                         common::enumNamesText<UpAxis>(", ", ", ") + ")");
}

OrbitAxes OrbitAxes::of(UpAxis axis) {
  const int a = int(axis) / 2;
  OrbitAxes o;
  o.up = glm::dvec3(0.0);
  o.up[a] = int(axis) % 2 ? -1.0 : 1.0;
  o.front = a == 2 ? glm::dvec3{0, 1, 0} : glm::dvec3{0, 0, 1};  // the table in Camera.h
  o.side = glm::cross(o.up, o.front);
  return o;
}

glm::dvec3 OrbitAxes::eyeDirection(double azimuthDeg, double elevationDeg) const {
  const double az = glm::radians(azimuthDeg), el = glm::radians(elevationDeg);
  return std::cos(el) * (std::cos(az) * front + std::sin(az) * side) + std::sin(el) * up;
}

Camera Camera::orbitAt(double azimuthDeg, double elevationDeg, double distance, const Box& box, const OrbitAxes& axes) {
  if (!std::isfinite(azimuthDeg) || !std::isfinite(elevationDeg))
    throw RenderInputError("Camera::orbit: angles (" + numberText(azimuthDeg) + ", " + numberText(elevationDeg) +
                           ") are not finite");
  if (!(distance > 0) || !std::isfinite(distance))
    throw RenderInputError("Camera::orbit: distance " + numberText(distance) + " is not finite and positive");
  checkBox(box, "Camera::orbit");
  const double az = glm::radians(azimuthDeg), el = glm::radians(elevationDeg);
  const glm::dvec3 around = std::cos(az) * axes.front + std::sin(az) * axes.side;
  Camera camera;
  camera.center = box.center();
  camera.eye = camera.center + distance * axes.eyeDirection(azimuthDeg, elevationDeg);
  // Away from the pole the pole axis itself (negated past it) projects to exactly this derivative, so it is taken
  // as it is; near it (and at it, where the projection vanishes) the derivative.
  const double c = std::cos(el);
  camera.up = std::abs(c) > 1e-6 ? (c > 0 ? axes.up : -axes.up) : -std::sin(el) * around + c * axes.up;
  return camera;
}

Camera Camera::orbit(double azimuthDeg, double elevationDeg, double distanceInRadii, const Box& box,
                     const OrbitAxes& axes) {
  if (!(distanceInRadii > 0) || !std::isfinite(distanceInRadii))
    throw RenderInputError("Camera::orbit: distance " + numberText(distanceInRadii) +
                           " radii is not finite and positive");
  checkBox(box, "Camera::orbit");
  return orbitAt(azimuthDeg, elevationDeg, distanceInRadii * box.radius(), box, axes);
}

double Camera::fitDistance(double radius, double fovYDegrees, double aspect, bool orthographic) {
  if (!(radius > 0) || !std::isfinite(radius) || !(fovYDegrees > 0 && fovYDegrees <= 179) || !(aspect > 0) ||
      !std::isfinite(aspect))
    throw RenderInputError("Camera::fitDistance: radius " + numberText(radius) + ", fov " + numberText(fovYDegrees) +
                           " and aspect " + numberText(aspect) + " do not give a view");
  const double tanHalfY = std::tan(0.5 * glm::radians(fovYDegrees));
  const double r = kFitMargin * radius;
  if (orthographic) return std::max(r / (tanHalfY * std::min(1.0, aspect)), r);
  const double halfSmaller = std::atan(tanHalfY * std::min(1.0, aspect));
  return r / std::sin(halfSmaller);
}

void Camera::validate() const {
  if (!finite(eye)) throw RenderInputError("Camera: eye " + vecText(eye) + " is not finite");
  if (!finite(center)) throw RenderInputError("Camera: center " + vecText(center) + " is not finite");
  if (!finite(up)) throw RenderInputError("Camera: up " + vecText(up) + " is not finite");
  if (!(fovYDegrees > 0 && fovYDegrees <= 179))
    throw RenderInputError("Camera: fov " + numberText(fovYDegrees) + " degrees is outside (0, 179]");
  // The length can underflow to 0 or overflow to infinity even when eye != center; either leaves no direction.
  double d = distance();
  if (!(d > 0) || !std::isfinite(d))
    throw RenderInputError("Camera: eye " + vecText(eye) + " and center " + vecText(center) +
                           " do not define a view direction (distance " + numberText(d) + ")");
}

glm::dvec3 Camera::viewDirection() const {
  validate();
  return (center - eye) / distance();
}

glm::dvec3 Camera::upVector() const {
  glm::dvec3 d = viewDirection();
  double upLength = glm::length(up);
  if (upLength > 0 && std::isfinite(upLength)) {
    glm::dvec3 u = up / upLength;
    u -= glm::dot(u, d) * d;
    double left = glm::length(u);
    if (left > 1e-9) return u / left;
  }
  glm::dvec3 axis = std::abs(d.x) < 0.9 ? glm::dvec3{1.0, 0.0, 0.0} : glm::dvec3{0.0, 1.0, 0.0};
  return glm::normalize(glm::cross(axis, d));
}

glm::dmat4 Camera::view() const { return glm::lookAt(eye, center, upVector()); }

glm::dmat4 Camera::projection(double aspect, double near, double far) const {
  validate();
  if (!(aspect > 0) || !std::isfinite(aspect))
    throw RenderInputError("Camera::projection: aspect " + numberText(aspect) + " is not finite and positive");
  if (!(near > 0 && near < far) || !std::isfinite(far))
    throw RenderInputError("Camera::projection: near " + numberText(near) + " and far " + numberText(far) +
                           " do not satisfy 0 < near < far < inf");
  double halfFov = 0.5 * glm::radians(fovYDegrees);
  if (!orthographic) return glm::perspective(2 * halfFov, aspect, near, far);
  double halfHeight = distance() * std::tan(halfFov);
  double halfWidth = halfHeight * aspect;
  return glm::ortho(-halfWidth, halfWidth, -halfHeight, halfHeight, near, far);
}

void Camera::clipRange(const Box& box, double& near, double& far) const {
  checkBox(box, "Camera::clipRange");
  glm::dvec3 d = viewDirection();
  double zMin = std::numeric_limits<double>::infinity(), zMax = -zMin;
  for (int c = 0; c < 8; ++c) {
    glm::dvec3 corner{(c & 1) ? box.max.x : box.min.x, (c & 2) ? box.max.y : box.min.y,
                      (c & 4) ? box.max.z : box.min.z};
    double z = glm::dot(corner - eye, d);
    zMin = std::min(zMin, z);
    zMax = std::max(zMax, z);
  }
  // The GL side builds float matrices: the relative margin absorbs their round-off at the depth of the box, the
  // absolute one the round-off of the corner depths themselves.
  double pad = 1e-6 * (zMax - zMin) + 1e-5 * std::max(std::abs(zMin), std::abs(zMax));
  double nearest = 1e-4 * box.radius();
  near = std::max(zMin - pad, nearest);
  far = std::max(zMax + pad, 2 * nearest);
  // A distant camera gives far/near close to 1, where float depth (f+n)/(f-n) cancels catastrophically.
  near = std::min(near, far * (1 - 1e-3));
}

Frustum Frustum::fromMatrix(const glm::dmat4& m) {
  auto row = [&m](int r) { return glm::dvec4{m[0][r], m[1][r], m[2][r], m[3][r]}; };
  Frustum f;
  f.planes[0] = row(3) + row(0);
  f.planes[1] = row(3) - row(0);
  f.planes[2] = row(3) + row(1);
  f.planes[3] = row(3) - row(1);
  f.planes[4] = row(3) + row(2);
  f.planes[5] = row(3) - row(2);
  for (glm::dvec4& plane : f.planes) {
    double length = glm::length(glm::dvec3(plane));
    if (length > 0) plane /= length;
  }
  return f;
}

bool Frustum::intersects(const Box& box) const {
  for (const glm::dvec4& plane : planes) {
    glm::dvec3 normal(plane);
    // The corner furthest along the normal is inside if any point of the box is.
    glm::dvec3 corner{normal.x >= 0 ? box.max.x : box.min.x, normal.y >= 0 ? box.max.y : box.min.y,
                      normal.z >= 0 ? box.max.z : box.min.z};
    double s = glm::dot(normal, corner) + plane.w;
    // Round-off in the plane test must never cull a box that touches the frustum.
    double tolerance = 1e-12 * (std::abs(plane.w) + glm::dot(glm::abs(normal), glm::abs(corner)));
    if (s < -tolerance) return false;
  }
  return true;
}

RayBasis RayBasis::of(const Camera& camera, double aspect, double nearPlane) {
  RayBasis b;
  b.eye = camera.eye;
  b.forward = camera.viewDirection();
  b.up = camera.upVector();
  b.right = glm::normalize(glm::cross(b.forward, b.up));
  b.up = glm::cross(b.right, b.forward);
  b.orthographic = camera.orthographic;
  b.tanHalfFov = std::tan(0.5 * glm::radians(camera.fovYDegrees));
  b.halfHeight = camera.distance() * b.tanHalfFov;
  b.aspect = aspect;
  b.nearPlane = nearPlane;
  return b;
}

void RayBasis::pixelRay(int x, int y, int width, int height, glm::dvec3& origin, glm::dvec3& direction,
                        double& tNear) const {
  const double sx = 2.0 * (x + 0.5) / width - 1.0;
  const double sy = 1.0 - 2.0 * (y + 0.5) / height;
  if (orthographic) {
    origin = eye + sx * halfHeight * aspect * right + sy * halfHeight * up;
    direction = forward;
    tNear = nearPlane;
  } else {
    origin = eye;
    direction = glm::normalize(forward + sx * tanHalfFov * aspect * right + sy * tanHalfFov * up);
    tNear = nearPlane / glm::dot(direction, forward);
  }
}

}  // namespace voxbrick::render
