// The tetrahedral reference renderer (render/reference/TetReference.h): closed forms on a single tet, convergence of
// brute force to it, the same image from two splittings of a cube (rays through edges and vertices included), a grid of
// tets against one analytic segment per ray, order along the ray, perspective, and the grid reference on a box.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "TetMeshes.h"
#include "TetReferenceChecks.h"
#include "mesh/TetMesh.h"
#include "render/RenderFixtures.h"
#include "render/core/RenderErrors.h"
#include "render/core/SegmentIntegral.h"
#include "render/reference/TetReference.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::kPresets;
using test::preset;

using test::bruteForce;
using test::cameras;
using test::clipToBox;
using test::clipToTet;
using test::cornerTet;
using test::cube;
using test::Field;
using test::kuhnGrid;
using test::makeMesh;
using test::maxDifference;
using test::oneSegment;
using test::perspectiveDirection;

TransferFunction constantTf(const glm::dvec3& rgb, double alpha) {
  return TransferFunction({{0.0, glm::dvec4(rgb, alpha)}, {1.0, glm::dvec4(rgb, alpha)}});
}

TetReferenceParams orthoDownZ(double cx, double cy, double fov, int width, int height) {
  TetReferenceParams p;
  p.camera.eye = {cx, cy, 5};
  p.camera.center = {cx, cy, 0};
  p.camera.orthographic = true;
  p.camera.fovYDegrees = fov;
  p.width = width, p.height = height;
  return p;
}

// A constant scalar: each pixel's opacity is 1 - (1 - a)^(len / L_ref) with len the chord through the tet, here
// 1 - x - y for a view down z onto the corner tet. Pixel centres as the grid reference places them.
TEST(TetReference, ConstantTetOrthographicIsTheClosedForm) {
  const mesh::TetMesh tet = cornerTet([](const glm::dvec3&) { return 0.5; });
  TetReferenceParams p = orthoDownZ(0.3, 0.3, 20, 40, 32);
  const double alpha = 0.3;
  p.transferFunction = constantTf({1, 1, 1}, alpha);
  p.referenceLength = 0.25;
  p.background = {0, 0, 1};
  const TetReference reference(tet);
  TetReferenceStats stats;
  const image::ImageF image = reference.render(p, &stats);
  const double halfHeight = 5 * std::tan(glm::radians(10.0)), aspect = 40.0 / 32;
  int inside = 0;
  double worst = 0;
  for (int y = 0; y < p.height; ++y)
    for (int x = 0; x < p.width; ++x) {
      const double wx = 0.3 + (2.0 * (x + 0.5) / p.width - 1) * halfHeight * aspect;
      const double wy = 0.3 + (1 - 2.0 * (y + 0.5) / p.height) * halfHeight;
      const double length = wx >= 0 && wy >= 0 ? std::max(0.0, 1 - wx - wy) : 0.0;
      const double opacity = 1 - std::pow(1 - alpha, length / p.referenceLength);
      inside += length > 0;
      ASSERT_NEAR(image.pixel(x, y)[0], opacity, 2e-7) << x << ", " << y;
      ASSERT_NEAR(image.pixel(x, y)[1], opacity, 2e-7);
      ASSERT_NEAR(image.pixel(x, y)[2], 1.0, 2e-7) << "white over blue: blue stays 1";
      // In double, through the same ray.
      const glm::dvec4 c = reference.integrate(reference.pixelRay(p, x, y), p);
      worst = std::max(worst, std::abs(c.a - opacity));
    }
  EXPECT_GT(inside, 100);
  EXPECT_LT(worst, 1e-14);
  EXPECT_EQ(stats.rays, inside);
  EXPECT_EQ(stats.ambiguous, 0);
  std::printf("[ tet-ref ] constant tet: max |opacity - closed form| %.2g in double over %d rays\n", worst, inside);
}

// A linear scalar on a skewed tet, orthographic and oblique perspective rays: the midpoint rule converges to the
// reference as O(h^2) (the error falls 4x per doubling), its Richardson extrapolation meets it to 1e-9, and 20000
// steps to 1e-6. The segment's ends are those of an independent clip (Cyrus–Beck).
TEST(TetReference, LinearTetMatchesFineIntegration) {
  const std::array<glm::dvec3, 4> corners = {glm::dvec3(0, 0, 0), glm::dvec3(1.2, 0.1, 0), glm::dvec3(0.2, 1, 0.1),
                                             glm::dvec3(0.1, 0.3, 1.1)};
  // Float vertices and scalars: the field is the linear function through the stored values.
  const Field exactField = [](const glm::dvec3& q) { return 0.1 + 0.5 * q.x + 0.3 * q.y + 0.6 * q.z; };
  const mesh::TetMesh tet = makeMesh({corners.begin(), corners.end()}, {{0, 1, 2, 3}}, exactField);
  std::array<glm::dvec3, 4> stored;
  glm::dmat4 m(0.0);
  glm::dvec4 values;
  for (int i = 0; i < 4; ++i) {
    stored[size_t(i)] = glm::dvec3(tet.points[size_t(i)]);
    m[0][i] = stored[size_t(i)].x, m[1][i] = stored[size_t(i)].y, m[2][i] = stored[size_t(i)].z, m[3][i] = 1;
    values[i] = tet.scalars[size_t(i)];
  }
  const glm::dvec4 coefficients = glm::inverse(m) * values;
  const Field field = [&](const glm::dvec3& q) { return glm::dot(coefficients, glm::dvec4(q, 1)); };

  TetReferenceParams p;
  p.transferFunction = preset("hot");
  p.windowLo = 0.2, p.windowHi = 0.8;  // the field runs 0.1 to 0.9: both ends clamp
  p.referenceLength = 0.1;
  const TetReference reference(tet);
  const glm::dvec3 eye(2, 1.5, 3);
  std::vector<TetRay> rays;
  for (const glm::dvec2& xy : {glm::dvec2(0.3, 0.3), glm::dvec2(0.5, 0.2), glm::dvec2(0.2, 0.6)}) {
    TetRay ray;
    ray.origin = {xy.x, xy.y, 4};
    ray.direction = {0, 0, -1};
    rays.push_back(ray);
  }
  for (const glm::dvec3& target : {glm::dvec3(0.35, 0.35, 0.3), glm::dvec3(0.6, 0.2, 0.1), glm::dvec3(0.2, 0.5, 0.5)}) {
    TetRay ray;
    ray.origin = eye;
    ray.direction = glm::normalize(target - eye);
    ray.right = glm::normalize(glm::cross(ray.direction, glm::dvec3(0, 1, 0)));
    ray.up = glm::cross(ray.right, ray.direction);
    rays.push_back(ray);
  }
  for (const TetRay& ray : rays) {
    double t0 = 0, t1 = 0;
    ASSERT_TRUE(clipToTet(stored, ray.origin, ray.direction, t0, t1));
    const std::vector<TetSegment> segments = reference.segments(ray);
    ASSERT_EQ(segments.size(), 1u);
    EXPECT_NEAR(segments[0].t0, t0, 1e-13);
    EXPECT_NEAR(segments[0].t1, t1, 1e-13);
    EXPECT_NEAR(segments[0].value0, field(ray.origin + t0 * ray.direction), 1e-13);
    EXPECT_NEAR(segments[0].value1, field(ray.origin + t1 * ray.direction), 1e-13);
    const glm::dvec4 exact = reference.integrate(ray, p);
    std::printf("[ tet-ref ] chord %.3f, opacity %.4f; |midpoint - reference| by steps:", t1 - t0, exact.a);
    double previous = 0;
    for (int n : {250, 500, 1000, 2000}) {
      const double error = maxDifference(bruteForce(p, field, ray.origin, ray.direction, t0, t1, n), exact);
      std::printf(" %d: %.3g", n, error);
      if (previous > 0) {
        EXPECT_GT(previous / error, 3.5) << n;
        EXPECT_LT(previous / error, 4.5) << n;
      }
      previous = error;
    }
    const glm::dvec4 coarse = bruteForce(p, field, ray.origin, ray.direction, t0, t1, 1000);
    const glm::dvec4 fine = bruteForce(p, field, ray.origin, ray.direction, t0, t1, 1000, 2);
    const double extrapolated = maxDifference(fine + (fine - coarse) / 3.0, exact);
    const double converged = maxDifference(bruteForce(p, field, ray.origin, ray.direction, t0, t1, 20000), exact);
    std::printf("; extrapolated %.2g, 20000 steps %.2g\n", extrapolated, converged);
    EXPECT_LT(extrapolated, 1e-9);
    EXPECT_LT(converged, 1e-6);
  }
}

// A linear field is represented exactly by any split of a cube, so the 5-tet and the 6-tet (Kuhn) cube must give
// the same image, and every ray the single segment of the field across the cube. Rays on a lattice of 1/8 run
// exactly through vertices, edges and in the planes of faces (inner diagonal faces too, for views along an axis);
// there the tie rule puts the ray on the side of +right, then +up: inside for [0, 1) x [0, 1) of the cube's face,
// as the grid's half-open rule. A face counted twice or missed would show as a difference of a whole segment.
TEST(TetReference, FiveAndSixTetCubesAgreeThroughEdgesAndVertices) {
  // Dyadic coefficients: the float scalars at the corners are the field's exact values.
  const Field field = [](const glm::dvec3& q) { return 0.25 + 0.25 * q.x - 0.125 * q.y + 0.5 * q.z; };
  const TetReference five(cube(false, field)), six(cube(true, field));
  TetReferenceParams p;
  p.transferFunction = preset("hot");
  p.referenceLength = 0.2;
  double worst = 0;
  int rays = 0, inside = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int direction : {-1, 1})
      for (int i = -1; i <= 9; ++i)
        for (int j = -1; j <= 9; ++j) {
          TetRay ray;
          ray.direction = glm::dvec3(0.0), ray.right = glm::dvec3(0.0), ray.up = glm::dvec3(0.0);
          ray.direction[axis] = direction;
          ray.right[(axis + 1) % 3] = 1;
          ray.up[(axis + 2) % 3] = 1;
          ray.origin[axis] = direction > 0 ? -2 : 3;
          ray.origin[(axis + 1) % 3] = i / 8.0;
          ray.origin[(axis + 2) % 3] = j / 8.0;
          const bool in = i >= 0 && i < 8 && j >= 0 && j < 8;
          const glm::dvec4 expected = in ? oneSegment(p, field, ray.origin, ray.direction, 2, 3) : glm::dvec4(0.0);
          for (const TetReference* mesh : {&five, &six}) {
            int64_t ambiguous = 0;
            const std::vector<TetSegment> segments = mesh->segments(ray, &ambiguous);
            EXPECT_EQ(ambiguous, 0);
            for (size_t k = 0; k + 1 < segments.size(); ++k) {
              // Neighbours meet end to start, bit for bit, in position and value.
              EXPECT_EQ(segments[k].t1, segments[k + 1].t0);
              EXPECT_EQ(segments[k].value1, segments[k + 1].value0);
            }
            const double error = maxDifference(mesh->integrate(ray, p), expected);
            EXPECT_LT(error, 1e-13) << (mesh == &five ? "5" : "6") << " tets, axis " << axis << ", direction "
                                    << direction << ", at " << i << "/8, " << j << "/8";
            worst = std::max(worst, error);
          }
          ++rays, inside += in;
        }
  std::printf("[ tet-ref ] cube, %d lattice rays (%d inside): max |mesh - one segment| %.2g\n", rays, inside, worst);

  // Whole frames, perspective and orthographic, oblique and along an axis through the lattice's middle.
  const mesh::TetMesh fiveMesh = cube(false, field), sixMesh = cube(true, field);
  for (const auto& [name, spec] : cameras(TetReference(fiveMesh).bounds())) {
    Scene scene;
    scene.camera = spec;
    scene.width = 48, scene.height = 40;
    scene.transferFunction = preset("hot");
    const TetReferenceParams q = TetReferenceParams::fromScene(scene, fiveMesh, 0.2);
    TetReferenceStats stats;
    const image::ImageF a = renderTetReference(fiveMesh, q, &stats), b = renderTetReference(sixMesh, q);
    test::expectClose(a, b, 1e-6, "tet-cube-" + name);
    std::printf("[ tet-ref ] cube, %-9s 5 against 6 tets: max |diff| %.2g\n", name.c_str(),
                image::compareImages(a, b).maxAbs);
    EXPECT_GT(test::meanBrightness(a), 0.01) << name;
    EXPECT_EQ(stats.ambiguous, 0);
  }
}

// 16^3 cubes of 6 tets (24576) of a linear field: every pixel ray, whatever tets it crosses, composites to the one
// segment of the field across the cube's box, to 1e-12. Vertices on a grid of 1/8 and dyadic coefficients keep the
// float mesh exactly that field.
TEST(TetReference, GridOfTetsIsOneSegmentPerRay) {
  const Field field = [](const glm::dvec3& q) { return 0.5 + 0.25 * q.x + 0.125 * q.y - 0.125 * q.z; };
  const mesh::TetMesh grid = kuhnGrid(16, -1, 1, field);
  const TetReference reference(grid);
  for (bool orthographic : {false, true}) {
    Scene scene;
    scene.camera.azimuth = 37, scene.camera.elevation = 23, scene.camera.orthographic = orthographic;
    scene.width = 64, scene.height = 56;
    scene.transferFunction = preset("mri");
    scene.window = std::array<double, 2>{0.2, 0.9};
    const TetReferenceParams p = TetReferenceParams::fromScene(scene, grid, 0.1);
    TetReferenceStats stats;
    const image::ImageF image = reference.render(p, &stats);
    EXPECT_EQ(stats.ambiguous, 0);
    double worst = 0;
    for (int y = 0; y < p.height; ++y)
      for (int x = 0; x < p.width; ++x) {
        const TetRay ray = reference.pixelRay(p, x, y);
        double t0 = 0, t1 = 0;
        glm::dvec4 expected(0.0);
        if (clipToBox(glm::dvec3(-1), glm::dvec3(1), ray.origin, ray.direction, t0, t1))
          expected = oneSegment(p, field, ray.origin, ray.direction, std::max(t0, ray.tNear), t1);
        worst = std::max(worst, maxDifference(reference.integrate(ray, p), expected));
        const glm::dvec3 out = glm::dvec3(expected) + (1 - expected.a) * p.background;
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(image.pixel(x, y)[c], out[c], 2e-7);
      }
    EXPECT_LT(worst, 1e-12);
    std::printf(
        "[ tet-ref ] %zu tets, %s %dx%d: %.1f ms, %lld rays, %.1f segments and %.1f tet tests per ray; "
        "max |mesh - one segment| %.2g\n",
        grid.tets.size(), orthographic ? "orthographic" : "perspective", p.width, p.height, stats.ms,
        (long long)stats.rays, double(stats.segments) / double(stats.rays),
        double(stats.tetTests) / double(p.width * p.height), worst);
  }
}

// Cameras on symmetry planes of the mesh (azimuth 0 and 45, elevation 0, 90 and along the cube's diagonal, odd
// image sizes so that a pixel centre lies on the view axis) put rays in the planes of faces, through edges and
// along the diagonal edges of Kuhn's cubes, where the side tests are zero up to rounding: the tie rule must still
// give every ray exactly the one segment of the field across the box.
TEST(TetReference, SymmetricViewsGiveOneSegmentPerRay) {
  const Field field = [](const glm::dvec3& q) { return 0.5 + 0.25 * q.x + 0.125 * q.y - 0.125 * q.z; };
  const double diagonal = glm::degrees(std::atan(1 / std::sqrt(2.0)));
  for (const mesh::TetMesh& mesh : {cube(false, field, -1, 1), kuhnGrid(4, -1, 1, field)}) {
    const TetReference reference(mesh);
    double worst = 0;
    for (double azimuth : {0.0, 45.0})
      for (double elevation : {0.0, diagonal, 90.0})
        for (bool orthographic : {false, true}) {
          Scene scene;
          scene.camera.azimuth = azimuth, scene.camera.elevation = elevation;
          scene.camera.orthographic = orthographic;
          scene.width = scene.height = 33;
          scene.transferFunction = preset("mri");
          scene.window = std::array<double, 2>{0, 1};
          const TetReferenceParams p = TetReferenceParams::fromScene(scene, mesh, 0.1);
          for (int y = 0; y < p.height; ++y)
            for (int x = 0; x < p.width; ++x) {
              const TetRay ray = reference.pixelRay(p, x, y);
              int64_t ambiguous = 0;
              reference.segments(ray, &ambiguous);
              ASSERT_EQ(ambiguous, 0);
              double t0 = 0, t1 = 0;
              glm::dvec4 expected(0.0);
              if (clipToBox(glm::dvec3(-1), glm::dvec3(1), ray.origin, ray.direction, t0, t1))
                expected = oneSegment(p, field, ray.origin, ray.direction, std::max(t0, ray.tNear), t1);
              const double error = maxDifference(reference.integrate(ray, p), expected);
              ASSERT_LT(error, 1e-12) << mesh.tets.size() << " tets, azimuth " << azimuth << ", elevation " << elevation
                                      << (orthographic ? ", orthographic" : "") << ", pixel " << x << ", " << y;
              worst = std::max(worst, error);
            }
        }
    std::printf("[ tet-ref ] %zu tets, symmetric views: max |mesh - one segment| %.2g\n", mesh.tets.size(), worst);
  }
}

// Two tets apart along the ray (a non-convex mesh): the front one occludes, the gap adds nothing, and the order
// follows the view, not the tets' order in the mesh.
TEST(TetReference, SeparatedTetsCompositeFrontToBack) {
  // Value 0.2: red, alpha 0.6; value 0.8: blue, alpha 0.3 (a step at 0.5).
  TetReferenceParams p;
  p.transferFunction =
      TransferFunction({{0.0, {1, 0, 0, 0.6}}, {0.5, {1, 0, 0, 0.6}}, {0.5, {0, 0, 1, 0.3}}, {1.0, {0, 0, 1, 0.3}}});
  p.referenceLength = 0.5;
  const glm::dvec3 lift(0, 0, 3);
  std::vector<glm::dvec3> points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int i = 0; i < 4; ++i) points.push_back(points[size_t(i)] + lift);
  const Field field = [](const glm::dvec3& q) { return q.z > 2 ? 0.8 : 0.2; };
  const double chord = 1 - 0.2 - 0.2;
  const double red = 1 - std::pow(0.4, chord / 0.5), blue = 1 - std::pow(0.7, chord / 0.5);
  for (bool liftedFirst : {false, true}) {
    std::vector<mesh::Tet> tets = {{0, 1, 2, 3}, {4, 5, 6, 7}};
    if (liftedFirst) std::swap(tets[0], tets[1]);
    const TetReference reference(makeMesh(points, tets, field));
    TetRay down;
    down.origin = {0.2, 0.2, 10};
    down.direction = {0, 0, -1};
    const glm::dvec4 fromAbove = reference.integrate(down, p);
    EXPECT_NEAR(fromAbove.b, blue, 1e-14);
    EXPECT_NEAR(fromAbove.r, (1 - blue) * red, 1e-14);
    EXPECT_NEAR(fromAbove.a, 1 - (1 - blue) * (1 - red), 1e-14);
    TetRay upwards = down;
    upwards.origin.z = -10;
    upwards.direction = {0, 0, 1};
    const glm::dvec4 fromBelow = reference.integrate(upwards, p);
    EXPECT_NEAR(fromBelow.r, red, 1e-14);
    EXPECT_NEAR(fromBelow.b, (1 - red) * blue, 1e-14);
    EXPECT_NEAR(fromBelow.a, fromAbove.a, 1e-14);
    const std::vector<TetSegment> segments = reference.segments(down);
    ASSERT_EQ(segments.size(), 2u);
    EXPECT_EQ(segments[0].tet, liftedFirst ? 0u : 1u);               // the lifted tet is nearer the eye
    EXPECT_NEAR(segments[1].t0 - segments[0].t1, 3 - chord, 1e-13);  // the gap
  }
}

// Perspective: each pixel against its analytic chord (Cyrus–Beck on the pixel's ray), from outside and from inside
// the tet (the near plane cuts it); a distant perspective camera approaches the orthographic image.
TEST(TetReference, PerspectiveCameraMatchesAnalyticChords) {
  const mesh::TetMesh tet = cornerTet([](const glm::dvec3&) { return 0.5; });
  const std::array<glm::dvec3, 4> corners = {glm::dvec3(0, 0, 0), glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0),
                                             glm::dvec3(0, 0, 1)};
  const TetReference reference(tet);
  const double alpha = 0.4;
  for (const auto& [eye, center, fov] : std::vector<std::tuple<glm::dvec3, glm::dvec3, double>>{
           {{1.5, 1.2, 2.5}, {0.25, 0.25, 0.25}, 35.0}, {{0.15, 0.12, 0.1}, {0.5, 0.3, 0.4}, 90.0}}) {
    TetReferenceParams p;
    p.camera.eye = eye, p.camera.center = center, p.camera.fovYDegrees = fov;
    p.width = 48, p.height = 40;
    p.transferFunction = constantTf({1, 1, 1}, alpha);
    p.referenceLength = 0.2;
    const image::ImageF image = reference.render(p);
    double nearPlane = 0, farPlane = 0;
    p.camera.clipRange(reference.bounds(), nearPlane, farPlane);
    int inside = 0;
    double worst = 0;
    for (int y = 0; y < p.height; ++y)
      for (int x = 0; x < p.width; ++x) {
        const glm::dvec3 d = perspectiveDirection(p, x, y);
        const TetRay ray = reference.pixelRay(p, x, y);
        ASSERT_LT(glm::length(ray.direction - d), 1e-15);
        ASSERT_EQ(ray.origin, p.camera.eye);
        double t0 = 0, t1 = 0, length = 0;
        const double tNear = nearPlane / glm::dot(d, p.camera.viewDirection());
        if (clipToTet(corners, eye, d, t0, t1)) length = std::max(0.0, t1 - std::max(t0, tNear));
        const double opacity = 1 - std::pow(1 - alpha, length / p.referenceLength);
        inside += length > 0;
        ASSERT_NEAR(image.pixel(x, y)[0], opacity, 2e-7) << x << ", " << y;
        worst = std::max(worst, std::abs(reference.integrate(ray, p).a - opacity));
      }
    EXPECT_GT(inside, 100);
    EXPECT_LT(worst, 1e-13);
  }
  // 10^4 units away, the rays across the tet are parallel to within 1e-4.
  TetReferenceParams p;
  p.camera.eye = {0.3, 0.3, 1e4}, p.camera.center = {0.3, 0.3, 0.3}, p.camera.fovYDegrees = 0.008;
  p.width = p.height = 40;
  p.transferFunction = constantTf({1, 1, 1}, alpha);
  p.referenceLength = 0.2;
  const image::ImageF perspective = reference.render(p);
  p.camera.orthographic = true;
  const image::ImageF orthographic = reference.render(p);
  const image::ImageError e = image::compareImages(perspective, orthographic);
  std::printf("[ tet-ref ] perspective at 10^4 against orthographic: max |diff| %.2g\n", e.maxAbs);
  EXPECT_LT(e.maxAbs, 1e-3);
  EXPECT_GT(test::meanBrightness(orthographic), 0.05);
}

// Frames comparable with the grid's: a box of constant value drawn by the grid reference (an 8^3 store of spacing 1/2)
// and by the tet reference (the box as 5 tets) from the same scene agree to float round-off, which pins the pixel
// centres, the camera, the near plane, the window, L_ref and the background to the same conventions.
TEST(TetReference, MatchesTheGridReferenceOnAConstantBox) {
  test::ScratchDir dir;
  auto store =
      test::prepArray({8, 8, 8}, store::ValueType::F32, std::vector<float>(512, 0.5f), dir / "box", 8, {0.5, 0.5, 0.5});
  const mesh::TetMesh box = cube(
      false, [](const glm::dvec3&) { return 0.5; }, -2, 2);
  for (const auto& [name, spec] : cameras(TetReference(box).bounds())) {
    Scene scene;
    scene.camera = spec;
    scene.width = 40, scene.height = 32;
    scene.window = std::array<double, 2>{0, 1};
    scene.transferFunction = TransferFunction({{0.0, {0.2, 0.6, 0.9, 0.15}}, {1.0, {0.2, 0.6, 0.9, 0.15}}}, 1.0);
    scene.background = {0.1, 0.2, 0.3};
    const image::ImageF grid = test::renderReference(store, scene);
    const image::ImageF tets = renderTetReference(box, TetReferenceParams::fromScene(scene, box, 1.0));
    test::expectClose(grid, tets, 1e-6, "tet-grid-box-" + name);
    std::printf("[ tet-ref ] box, %-9s grid reference against tets: max |diff| %.2g\n", name.c_str(),
                image::compareImages(grid, tets).maxAbs);
    EXPECT_GT(test::meanBrightness(tets), 0.1);
  }
}

TEST(TetReference, ParametersAndErrors) {
  const mesh::TetMesh constant = cornerTet([](const glm::dvec3&) { return 3.0; });
  Scene scene;
  scene.width = 8, scene.height = 6;
  TetReferenceParams p = TetReferenceParams::fromScene(scene, constant, 0.7);
  EXPECT_EQ(p.windowLo, 3);
  EXPECT_EQ(p.windowHi, 4);  // a constant mesh maps to 0, as a constant store does
  EXPECT_EQ(p.referenceLength, 0.7);
  EXPECT_EQ(p.width, 8);
  const mesh::TetMesh ramp = cornerTet([](const glm::dvec3& q) { return 1 + 4 * q.x; });
  p = TetReferenceParams::fromScene(scene, ramp, 0.7);
  EXPECT_EQ(p.windowLo, 1);
  EXPECT_EQ(p.windowHi, 5);
  scene.window = std::array<double, 2>{2, 3};
  scene.transferFunction = TransferFunction({{0.0, {0, 0, 0, 0}}, {1.0, {1, 1, 1, 1}}}, 0.25);
  p = TetReferenceParams::fromScene(scene, ramp, 0.7);
  EXPECT_EQ(p.windowLo, 2);
  EXPECT_EQ(p.referenceLength, 0.25);
  EXPECT_THROW(TetReferenceParams::fromScene(scene, mesh::TetMesh{}, 1), RenderInputError);

  const std::vector<std::function<void(TetReferenceParams&)>> changes = {
      [](TetReferenceParams& q) { q.width = 0; },
      [](TetReferenceParams& q) { q.height = 9000; },
      [](TetReferenceParams& q) { q.windowHi = q.windowLo; },
      [](TetReferenceParams& q) { q.windowLo = NAN; },
      [](TetReferenceParams& q) { q.referenceLength = 0; },
      [](TetReferenceParams& q) { q.referenceLength = INFINITY; },
      [](TetReferenceParams& q) {
        q.background = {0, 2, 0};
      },
      [](TetReferenceParams& q) { q.camera.eye = q.camera.center; },
  };
  for (const auto& change : changes) {
    TetReferenceParams q;
    change(q);
    EXPECT_THROW(q.validate(), RenderInputError);
    EXPECT_THROW(TetReference(constant).render(q), RenderInputError);
  }

  mesh::TetMesh broken = constant;
  broken.tets[0][2] = 9;
  EXPECT_THROW(TetReference{broken}, RenderInputError);
  broken = constant;
  broken.scalars.pop_back();
  EXPECT_THROW(TetReference{broken}, RenderInputError);

  // Nothing to draw: an empty mesh, a flat tet. Every pixel is the background.
  mesh::TetMesh flat = constant;
  flat.points[3] = {0.5f, 0.5f, 0.0f};
  TetReferenceParams q = orthoDownZ(0.3, 0.3, 40, 8, 8);
  q.transferFunction = constantTf({1, 1, 1}, 1);
  q.background = {0.25, 0.5, 0.75};
  for (const mesh::TetMesh& nothing : {mesh::TetMesh{}, flat}) {
    TetReferenceStats stats;
    const image::ImageF image = renderTetReference(nothing, q, &stats);
    EXPECT_EQ(stats.rays, 0);
    for (int i = 0; i < 64; ++i) EXPECT_EQ(image.rgba[size_t(4 * i + 1)], 0.5f);
  }
}

}  // namespace
}  // namespace voxbrick::render
