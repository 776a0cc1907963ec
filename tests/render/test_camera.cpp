// Camera math: volume boxes, orbit placement, view basis, matrices, clip range, frustum tests and validation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <glm/glm.hpp>

#include "render/core/Camera.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::render {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

glm::dvec3 toNdc(const glm::dmat4& m, const glm::dvec3& p) {
  glm::dvec4 c = m * glm::dvec4(p, 1.0);
  return glm::dvec3(c) / c.w;
}

// The same in single precision, as the GL side will compute it.
glm::vec3 toNdcFloat(const glm::dmat4& m, const glm::dvec3& p) {
  glm::vec4 c = glm::mat4(m) * glm::vec4(glm::vec3(p), 1.0f);
  return glm::vec3(c) / c.w;
}

glm::dvec3 corner(const Box& box, int c) {
  return {(c & 1) ? box.max.x : box.min.x, (c & 2) ? box.max.y : box.min.y, (c & 4) ? box.max.z : box.min.z};
}

void expectNear(const glm::dvec3& a, const glm::dvec3& b, double tolerance) {
  EXPECT_NEAR(a.x, b.x, tolerance);
  EXPECT_NEAR(a.y, b.y, tolerance);
  EXPECT_NEAR(a.z, b.z, tolerance);
}

// The message of the RenderInputError that `f` throws; fails the test if it throws nothing or something else.
template <typename F>
std::string inputError(F&& f) {
  try {
    f();
  } catch (const RenderInputError& e) {
    return e.what();
  } catch (...) {
    ADD_FAILURE() << "threw something other than RenderInputError";
    return {};
  }
  ADD_FAILURE() << "did not throw";
  return {};
}

void expectValidBasis(const Camera& camera) {
  glm::dvec3 d = camera.viewDirection(), u = camera.upVector();
  EXPECT_NEAR(glm::length(d), 1.0, 1e-12);
  EXPECT_NEAR(glm::length(u), 1.0, 1e-12);
  EXPECT_NEAR(glm::dot(d, u), 0.0, 1e-12);
  glm::dmat4 v = camera.view();
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) EXPECT_TRUE(std::isfinite(v[c][r]));
  // The rotation part is orthonormal and maps the view direction to -Z, up to +Y.
  expectNear(glm::dmat3(v) * d, {0, 0, -1}, 1e-12);
  expectNear(glm::dmat3(v) * u, {0, 1, 0}, 1e-12);
}

TEST(CameraBox, VolumeBoxIsCentredWithExtentDimsTimesSpacing) {
  Box box = volumeBox({4, 2, 1}, {0.5, 1.0, 2.0});
  expectNear(box.min, {-1, -1, -1}, 0);
  expectNear(box.max, {1, 1, 1}, 0);
  expectNear(box.center(), {0, 0, 0}, 0);
  expectNear(box.extent(), {2, 2, 2}, 0);
  EXPECT_DOUBLE_EQ(box.radius(), std::sqrt(3.0));
  EXPECT_NE(inputError([] { volumeBox({4, 0, 1}, {1, 1, 1}); }).find("dims[1] = 0"), std::string::npos);
  EXPECT_NE(inputError([] { volumeBox({4, 2, 1}, {1, -2, 1}); }).find("spacing[1] = -2"), std::string::npos);
  inputError([] { volumeBox({4, 2, 1}, {1, 1, kNaN}); });
}

TEST(CameraOrbit, AzimuthAndElevationPlaceTheEye) {
  Box box = volumeBox({10, 20, 30}, {1, 1, 1});
  box.min += glm::dvec3(1, 2, 3);  // off-centre, so the orbit must use the box centre
  box.max += glm::dvec3(1, 2, 3);
  double r = box.radius();
  Camera front = Camera::orbit(0, 0, 3, box);
  expectNear(front.eye, box.center() + glm::dvec3(0, 0, 3 * r), 1e-9);
  expectNear(front.center, box.center(), 0);
  expectNear(front.viewDirection(), {0, 0, -1}, 1e-12);
  Camera side = Camera::orbit(90, 0, 2, box);
  expectNear(side.eye, box.center() + glm::dvec3(2 * r, 0, 0), 1e-9);
  Camera general = Camera::orbit(30, 40, 1.5, box);
  double az = glm::radians(30.0), el = glm::radians(40.0);
  glm::dvec3 offset{std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az)};
  expectNear(general.eye, box.center() + 1.5 * r * offset, 1e-9);
  expectValidBasis(front);
  expectValidBasis(side);
  expectValidBasis(general);
  // Away from the poles, up is +Y made orthogonal to the view direction.
  glm::dvec3 d = general.viewDirection(), y{0, 1, 0};
  expectNear(general.upVector(), glm::normalize(y - glm::dot(y, d) * d), 1e-12);
}

TEST(CameraOrbit, PolesGiveAValidBasisContinuousWithAzimuthZero) {
  Box box = volumeBox({8, 8, 8}, {1, 1, 1});
  Camera top = Camera::orbit(0, 90, 2, box);
  expectNear(top.eye, {0, 2 * box.radius(), 0}, 1e-9);
  expectValidBasis(top);
  expectNear(top.upVector(), {0, 0, -1}, 1e-9);
  // Just below the pole the ordinary projection of +Y agrees with the fallback.
  expectNear(Camera::orbit(0, 89.999, 2, box).upVector(), {0, 0, -1}, 1e-4);
  Camera bottom = Camera::orbit(0, -90, 2, box);
  expectValidBasis(bottom);
  expectNear(bottom.upVector(), {0, 0, 1}, 1e-9);
  // Up parallel to a view along X, and a zero up, still give a basis.
  Camera alongX;
  alongX.eye = {5, 0, 0};
  alongX.up = {-3, 0, 0};
  expectValidBasis(alongX);
  Camera zeroUp;
  zeroUp.up = {0, 0, 0};
  expectValidBasis(zeroUp);
}

TEST(CameraOrbit, UpAxesFollowTheTable) {
  const Box box = volumeBox({8, 8, 8}, {1, 1, 1});
  const double r = box.radius();
  // +z (the default of a scene): az 0 from +y (anterior), az 90 from -x (the patient's left), el 90 from +z.
  const OrbitAxes z = OrbitAxes::ofUpAxis("+z", "test");
  expectNear(Camera::orbit(0, 0, 2, box, z).eye, {0, 2 * r, 0}, 1e-9);
  expectNear(Camera::orbit(90, 0, 2, box, z).eye, {-2 * r, 0, 0}, 1e-9);
  expectNear(Camera::orbit(0, 90, 2, box, z).eye, {0, 0, 2 * r}, 1e-9);
  // Below the pole, screen-up is +z made orthogonal to the view direction.
  const Camera general = Camera::orbit(30, 20, 2, box, z);
  const glm::dvec3 d = general.viewDirection(), up{0, 0, 1};
  expectNear(general.upVector(), glm::normalize(up - glm::dot(up, d) * d), 1e-12);
  // +y is the default of Camera::orbit.
  const OrbitAxes y = OrbitAxes::ofUpAxis("y", "test");
  expectNear(Camera::orbit(30, 40, 1.5, box, y).eye, Camera::orbit(30, 40, 1.5, box).eye, 0);
  for (const char* name : {"+x", "-x", "+y", "-y", "+z", "-z"}) {
    const OrbitAxes a = OrbitAxes::ofUpAxis(name, "test");
    EXPECT_NEAR(glm::dot(glm::cross(a.front, a.side), a.up), 1.0, 1e-12) << name;  // side = up x front
    EXPECT_NEAR(glm::dot(a.front, a.up), 0.0, 0) << name;
    expectValidBasis(Camera::orbit(123, -45, 3, box, a));
  }
  EXPECT_NE(inputError([] { OrbitAxes::ofUpAxis("up", "--up-axis"); }).find("--up-axis: unknown up axis 'up'"),
            std::string::npos);
}

TEST(CameraOrbit, CrossingThePoleTurnsTheImageSmoothly) {
  // The up vector is continuous through el 90 (the old orbit's +Y projection flipped there), for both up axes.
  const Box box = volumeBox({8, 8, 8}, {1, 1, 1});
  for (const char* name : {"+y", "+z"}) {
    const OrbitAxes axes = OrbitAxes::ofUpAxis(name, "test");
    for (double az : {0.0, 37.0, 200.0}) {
      const glm::dvec3 below = Camera::orbit(az, 89.9, 2, box, axes).upVector();
      const glm::dvec3 at = Camera::orbit(az, 90, 2, box, axes).upVector();
      const glm::dvec3 above = Camera::orbit(az, 90.1, 2, box, axes).upVector();
      EXPECT_LT(glm::length(below - at), 0.01) << name << " az " << az;
      EXPECT_LT(glm::length(above - at), 0.01) << name << " az " << az;
      // Past the pole the eye has moved on over the top: the same point as az + 180 at el 89.9.
      expectNear(Camera::orbit(az, 90.1, 2, box, axes).eye, Camera::orbit(az + 180, 89.9, 2, box, axes).eye, 1e-9);
    }
  }
}

TEST(CameraOrbit, FitDistanceKeepsEveryCornerInFrame) {
  // The whole box is in frame at any angle and aspect, and the margin is small: the old default (2.5 radii at a
  // 30-degree fov) cut corners off.
  const Box box = volumeBox({64, 40, 20}, {1, 1, 2});
  const double r = box.radius();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> angle(-180, 180);
  for (double aspect : {0.5, 1.0, 2.0})
    for (bool ortho : {false, true})
      for (double fov : {10.0, 30.0, 90.0}) {
        const double d = Camera::fitDistance(r, fov, aspect, ortho);
        double largest = 0;
        for (int i = 0; i < 20; ++i) {
          Camera c = Camera::orbitAt(angle(rng), angle(rng) / 2, d, box, {});
          c.fovYDegrees = fov;
          c.orthographic = ortho;
          double near = 0, far = 0;
          c.clipRange(box, near, far);
          const glm::dmat4 m = c.projection(aspect, near, far) * c.view();
          for (int k = 0; k < 8; ++k) {
            const glm::dvec3 p = toNdc(m, corner(box, k));
            largest = std::max({largest, std::abs(p.x), std::abs(p.y)});
          }
        }
        EXPECT_LE(largest, 1.0) << "aspect " << aspect << " ortho " << ortho << " fov " << fov;
        EXPECT_GT(largest, 0.5) << "aspect " << aspect << " ortho " << ortho << " fov " << fov;
      }
  EXPECT_GT(Camera::fitDistance(r, 30, 1, false), 3.8 * r);
  EXPECT_NE(inputError([] { Camera::fitDistance(1, 0, 1, false); }).find("fov 0"), std::string::npos);
}

TEST(CameraMatrices, ViewProjectionMapsTheCentreToTheMiddle) {
  for (bool ortho : {false, true}) {
    Camera camera;
    camera.eye = {3, 4, 5};
    camera.center = {1, -2, 0.5};
    camera.up = {0.3, 1, 0.2};
    camera.fovYDegrees = 40;
    camera.orthographic = ortho;
    glm::dmat4 vp = camera.projection(1.5, 0.1, 100) * camera.view();
    glm::dvec3 ndc = toNdc(vp, camera.center);
    EXPECT_NEAR(ndc.x, 0, 1e-12);
    EXPECT_NEAR(ndc.y, 0, 1e-12);
    EXPECT_GT(ndc.z, -1);
    EXPECT_LT(ndc.z, 1);
    // A point at the top edge of the view in the plane through the centre maps to y = 1, at the right edge x = 1.
    double halfHeight = camera.distance() * std::tan(glm::radians(20.0));
    glm::dvec3 right = glm::normalize(glm::cross(camera.viewDirection(), camera.upVector()));
    EXPECT_NEAR(toNdc(vp, camera.center + halfHeight * camera.upVector()).y, 1, 1e-12);
    EXPECT_NEAR(toNdc(vp, camera.center + 1.5 * halfHeight * right).x, 1, 1e-12);
    // Near and far planes map to -1 and 1.
    EXPECT_NEAR(toNdc(vp, camera.eye + 0.1 * camera.viewDirection()).z, -1, 1e-9);
    EXPECT_NEAR(toNdc(vp, camera.eye + 100.0 * camera.viewDirection()).z, 1, 1e-9);
  }
}

TEST(CameraMatrices, ExtremeFieldsOfViewStayFinite) {
  for (double fov : {1e-3, 90.0, 179.0}) {
    Camera camera;
    camera.fovYDegrees = fov;
    glm::dmat4 p = camera.projection(1, 0.01, 10);
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) EXPECT_TRUE(std::isfinite(p[c][r])) << fov;
    EXPECT_NEAR(toNdc(p * camera.view(), camera.center).x, 0, 1e-12);
  }
}

TEST(CameraFrustum, CullsBoxesOutsideAndKeepsBoxesInside) {
  Camera camera;
  camera.eye = {0, 0, 10};
  camera.center = {0, 0, 0};
  Frustum f = Frustum::fromMatrix(camera.projection(1, 1, 100) * camera.view());
  EXPECT_TRUE(f.intersects({{-1, -1, -1}, {1, 1, 1}}));
  EXPECT_FALSE(f.intersects({{-1, -1, 11}, {1, 1, 13}}));        // behind the eye
  EXPECT_FALSE(f.intersects({{-1, -1, 9.5}, {1, 1, 9.9}}));      // between the eye and the near plane
  EXPECT_FALSE(f.intersects({{-1, -1, -95}, {1, 1, -91}}));      // beyond the far plane
  EXPECT_FALSE(f.intersects({{20, -1, -1}, {22, 1, 1}}));        // off to the right
  EXPECT_TRUE(f.intersects({{-100, -100, -1}, {100, 100, 1}}));  // contains the whole cross-section
  EXPECT_TRUE(f.intersects({{2, -1, -1}, {22, 1, 1}}));          // straddles the right plane
  // A box touching a side plane from outside is kept: only boxes wholly outside are culled.
  double edge = 10 * std::tan(glm::radians(15.0));
  EXPECT_TRUE(f.intersects({{edge, -1, 0}, {edge + 1, 1, 0}}));
}

TEST(CameraClipRange, EnclosesEveryCornerOfTheBox) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-180, 180), dist(1.05, 20);
  Box box = volumeBox({30, 40, 50}, {1, 0.7, 1.3});
  for (int trial = 0; trial < 200; ++trial) {
    Camera camera = Camera::orbit(angle(rng), angle(rng) / 2, dist(rng), box);
    camera.orthographic = trial % 2 == 1;
    double near = 0, far = 0;
    camera.clipRange(box, near, far);
    ASSERT_GT(near, 0);
    ASSERT_LT(near, far);
    glm::dmat4 vp = camera.projection(1, near, far) * camera.view();
    for (int c = 0; c < 8; ++c) {
      double z = glm::dot(corner(box, c) - camera.eye, camera.viewDirection());
      EXPECT_GE(z, near);
      EXPECT_LE(z, far);
      glm::vec3 ndc = toNdcFloat(vp, corner(box, c));
      EXPECT_GE(ndc.z, -1.0f);
      EXPECT_LE(ndc.z, 1.0f);
    }
  }
}

TEST(CameraClipRange, EyeInsideTheBoxGetsASmallPositiveNear) {
  Box box = volumeBox({64, 64, 64}, {1, 1, 1});
  Camera camera;
  camera.eye = {5, -3, 2};
  camera.center = {0, 0, -20};
  double near = 0, far = 0;
  camera.clipRange(box, near, far);
  EXPECT_NEAR(near, 1e-4 * box.radius(), 1e-12);
  for (int c = 0; c < 8; ++c) EXPECT_LE(glm::dot(corner(box, c) - camera.eye, camera.viewDirection()), far);
  // Looking out through a face from just inside it: the range is still valid.
  camera.eye = {0, 0, 31.9999999};
  camera.center = {0, 0, 40};
  camera.clipRange(box, near, far);
  EXPECT_GT(near, 0);
  EXPECT_LT(near, far);
  // A box wholly behind the eye gives a valid, empty range.
  camera.eye = {0, 0, 100};
  camera.center = {0, 0, 200};
  camera.clipRange(box, near, far);
  EXPECT_GT(near, 0);
  EXPECT_LT(near, far);
}

TEST(CameraClipRange, DistantCameraKeepsTheOnePixelBoxInsideInSinglePrecision) {
  Box box = volumeBox({100, 100, 100}, {1, 1, 1});
  for (double distance : {1e4, 1e7, 1e9}) {
    Camera camera = Camera::orbit(20, 10, distance, box);
    double near = 0, far = 0;
    camera.clipRange(box, near, far);
    ASSERT_GT(near, 0);
    ASSERT_LT(near, far);
    EXPECT_GE(far - near, 1e-3 * far * (1 - 1e-12));
    glm::dmat4 vp = camera.projection(1, near, far) * camera.view();
    for (int c = 0; c < 8; ++c) {
      glm::dvec3 ndc = toNdc(vp, corner(box, c));
      EXPECT_LT(std::abs(ndc.x), 1.0 / 512) << distance;  // within a pixel of a 1024-pixel image
      glm::vec3 ndcFloat = toNdcFloat(vp, corner(box, c));
      EXPECT_TRUE(std::isfinite(ndcFloat.z));
      EXPECT_GE(ndcFloat.z, -1.0f) << distance;
      EXPECT_LE(ndcFloat.z, 1.0f) << distance;
    }
  }
}

TEST(CameraValidate, BadParametersThrowNamingTheValue) {
  Camera good;
  EXPECT_NO_THROW(good.validate());
  Camera c = good;
  c.center = c.eye;
  EXPECT_NE(inputError([&] { c.validate(); }).find("view direction"), std::string::npos);
  c = good;
  c.eye.x = kNaN;
  EXPECT_NE(inputError([&] { c.viewDirection(); }).find("eye"), std::string::npos);
  c = good;
  c.center.y = kInf;
  EXPECT_NE(inputError([&] { c.view(); }).find("center"), std::string::npos);
  c = good;
  c.up.z = kNaN;
  EXPECT_NE(inputError([&] { c.validate(); }).find("up"), std::string::npos);
  for (double fov : {0.0, -5.0, 179.5, 180.0, kNaN}) {
    c = good;
    c.fovYDegrees = fov;
    EXPECT_NE(inputError([&] { c.validate(); }).find("fov " + numberText(fov)), std::string::npos) << fov;
  }
  c = good;
  c.eye = {1e-320, 0, 0};  // different from the centre, but too close to give a direction
  c.center = {0, 0, 0};
  inputError([&] { c.validate(); });
  EXPECT_NE(inputError([&] { good.projection(0, 1, 2); }).find("aspect 0"), std::string::npos);
  EXPECT_NE(inputError([&] { good.projection(1, 0, 2); }).find("near 0"), std::string::npos);
  inputError([&] { good.projection(1, 2, 1); });
  inputError([&] { good.projection(1, 1, kInf); });
  Box box = volumeBox({2, 2, 2}, {1, 1, 1});
  EXPECT_NE(inputError([&] { Camera::orbit(0, 0, 0, box); }).find("distance 0"), std::string::npos);
  inputError([&] { Camera::orbit(kNaN, 0, 2, box); });
  inputError([&] { Camera::orbit(0, 0, 2, Box{}); });
  double near = 0, far = 0;
  inputError([&] { good.clipRange(Box{{0, 0, 0}, {0, 0, 0}}, near, far); });
}

}  // namespace
}  // namespace voxbrick::render
