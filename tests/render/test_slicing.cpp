// Tests of the GL-free slicer geometry: the exact box-plane polygon on hand cases, the Rezk-Salama CPU mirror
// against it on random and degenerate cases, Zellmann & Lang's path walk against the mirror, shared-face vertices of
// neighbouring boxes, and the global planes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <tuple>

#include "render/SliceCheck.h"
#include "render/core/RenderErrors.h"
#include "render/volume/SliceTables.h"
#include "render/volume/Slicing.h"

namespace voxbrick::render {
namespace {

using test::SliceCase;

const glm::dvec3 kUnitMin(0), kUnitMax(1);

// The exact polygon must be `expected` as a set (any start), convex, counter-clockwise seen along +n, of `area`.
void expectPolygon(const glm::dvec3& n, double d, std::vector<glm::dvec3> expected, double area) {
  const std::vector<glm::dvec3> got = intersectBoxPlane(kUnitMin, kUnitMax, n, d);
  const std::string where = "n " + test::vec3Text(n) + ", d " + std::to_string(d) + ": got " + test::polygonText(got);
  ASSERT_EQ(got.size(), expected.size()) << where;
  for (const glm::dvec3& e : expected) {
    bool found = false;
    for (const glm::dvec3& g : got) found = found || glm::length(g - e) < 1e-12;
    EXPECT_TRUE(found) << where << " lacks " << test::vec3Text(e);
  }
  for (size_t i = 0; i < got.size(); ++i) {
    const glm::dvec3 turn = glm::cross(got[(i + 1) % got.size()] - got[i], got[(i + 2) % got.size()] - got[i]);
    EXPECT_GT(glm::dot(turn, -n), 1e-12) << where << ": not a counter-clockwise turn at vertex " << i + 1;
  }
  EXPECT_NEAR(polygonArea(got, n), area, 1e-12) << where;
  // The mirror gives the same polygon, unless the plane is the box's back face (half-open boxes: see below).
  const auto mirror = rezkSalamaPolygon(kUnitMin, kUnitMax, n, d);
  const auto drawn = test::expectedSlice({kUnitMin, kUnitMax, n, d});
  const test::PolygonCheck check = test::checkPolygon(mirror, drawn, n, 1e-12);
  EXPECT_TRUE(check.failure.empty()) << where << ": mirror " << test::polygonText(mirror) << ": " << check.failure;
}

TEST(Slicing, TriangleQuadPentagonHexagon) {
  const double s3 = std::sqrt(3.0), s2 = std::sqrt(2.0), s6 = std::sqrt(6.0);
  expectPolygon(glm::dvec3(1, 1, 1) / s3, 0.5 / s3, {{0.5, 0, 0}, {0, 0.5, 0}, {0, 0, 0.5}}, s3 / 8);
  expectPolygon({0, 0, 1}, 0.5, {{0, 0, 0.5}, {1, 0, 0.5}, {1, 1, 0.5}, {0, 1, 0.5}}, 1);
  expectPolygon(glm::dvec3(1, 1, 0) / s2, 0.5 / s2, {{0.5, 0, 0}, {0, 0.5, 0}, {0, 0.5, 1}, {0.5, 0, 1}}, 1 / s2);
  // x + y + 2z = 1.5: the corners below it are 0, (1,0,0) and (0,1,0); five edges cross.
  expectPolygon({1, 1, 2}, 1.5, {{0, 0, 0.75}, {1, 0.5, 0}, {1, 0, 0.25}, {0.5, 1, 0}, {0, 1, 0.25}}, 0.875 * s6 / 2);
  expectPolygon(glm::dvec3(1, 1, 1) / s3, 1.5 / s3,
                {{1, 0.5, 0}, {0.5, 1, 0}, {0, 1, 0.5}, {0, 0.5, 1}, {0.5, 0, 1}, {1, 0, 0.5}}, 3 * s3 / 4);
  // The same hexagon seen from the other side runs the other way round in space but is again counter-clockwise.
  expectPolygon(-glm::dvec3(1, 1, 1) / s3, -1.5 / s3,
                {{1, 0.5, 0}, {0.5, 1, 0}, {0, 1, 0.5}, {0, 0.5, 1}, {0.5, 0, 1}, {1, 0, 0.5}}, 3 * s3 / 4);
}

TEST(Slicing, PlaneThroughVertexEdgeAndFace) {
  const double s2 = std::sqrt(2.0), s3 = std::sqrt(3.0);
  // Through three corners: exactly those corners, no repeats.
  expectPolygon({1, 1, 1}, 1, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, s3 / 2);
  // Through two opposite edges, diagonally.
  expectPolygon({1, -1, 0}, 0, {{0, 0, 0}, {1, 1, 0}, {1, 1, 1}, {0, 0, 1}}, s2);
  // Through one edge and across the box.
  expectPolygon({1, 1, 0}, 1, {{1, 0, 0}, {0, 1, 0}, {0, 1, 1}, {1, 0, 1}}, s2);
  // Containing a face, from either side.
  expectPolygon({0, 0, 1}, 0, {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, 1);
  expectPolygon({0, 0, -1}, -1, {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}, 1);
  expectPolygon({1, 0, 0}, 1, {{1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {1, 0, 1}}, 1);
  // Touching only a corner or only an edge: no area, so no polygon.
  EXPECT_TRUE(intersectBoxPlane(kUnitMin, kUnitMax, {1, 1, 1}, 0).empty());
  EXPECT_TRUE(intersectBoxPlane(kUnitMin, kUnitMax, {1, 1, 1}, 3).empty());
  EXPECT_TRUE(intersectBoxPlane(kUnitMin, kUnitMax, {1, 1, 0}, 0).empty());
  EXPECT_TRUE(intersectBoxPlane(kUnitMin, kUnitMax, {1, 1, 0}, 2).empty());
}

TEST(Slicing, BackFaceBelongsToTheNextBox) {
  // The exact polygon of a plane through the back face is that face; the slicer draws it with the box behind.
  const glm::dvec3 n(1, 0, 0);
  EXPECT_EQ(intersectBoxPlane(kUnitMin, kUnitMax, n, 1).size(), 4u);
  EXPECT_EQ(polygonArea(rezkSalamaPolygon(kUnitMin, kUnitMax, n, 1), n), 0);
  EXPECT_EQ(polygonArea(rezkSalamaPolygon({1, 0, 0}, {2, 1, 1}, n, 1), n), 1);
  EXPECT_EQ(polygonArea(rezkSalamaPolygon(kUnitMin, kUnitMax, -n, 0), -n), 0);
  EXPECT_EQ(polygonArea(rezkSalamaPolygon(kUnitMin, kUnitMax, -n, -1), -n), 1);
  EXPECT_EQ(planeIndexRange(kUnitMin, kUnitMax, n, 1.0).end, 1);
}

TEST(Slicing, PlanesJustOutsideGiveNothing) {
  for (const auto& [n, d] : std::vector<std::pair<glm::dvec3, double>>{{{0, 0, 1}, -1e-12},
                                                                       {{0, 0, 1}, 1 + 1e-12},
                                                                       {{1, 1, 1}, -1e-12},
                                                                       {{1, 1, 1}, 3 + 1e-12},
                                                                       {{-1, 2, 0.5}, -1 - 1e-12},
                                                                       {{-1, 2, 0.5}, 2.5 + 1e-12}}) {
    EXPECT_TRUE(intersectBoxPlane(kUnitMin, kUnitMax, n, d).empty()) << test::vec3Text(n) << " " << d;
    const auto mirror = rezkSalamaPolygon(kUnitMin, kUnitMax, n, d);
    EXPECT_EQ(polygonArea(mirror, n), 0) << test::vec3Text(n) << " " << d << ": " << test::polygonText(mirror);
  }
}

// Double round-off of both computations, relative to the case's scale times its edge conditioning (SliceCheck.h).
constexpr double kMirrorTolerance = 1e-12;

void expectMirrorMatches(const SliceCase& c, double& worst) {
  const auto mirror = rezkSalamaPolygon(c.boxMin, c.boxMax, c.n, c.d);
  const auto exact = test::expectedSlice(c);
  const double scale = test::caseScale(c) * test::edgeConditioning(exact, c);
  const test::PolygonCheck check = test::checkPolygon(mirror, exact, c.n, kMirrorTolerance * scale);
  worst = std::max(worst, check.error / scale);
  ASSERT_TRUE(check.failure.empty()) << test::caseText(c) << "\n  mirror " << test::polygonText(mirror) << "\n  exact  "
                                     << test::polygonText(exact) << "\n  " << check.failure;
}

TEST(Slicing, MirrorMatchesExactOnRandomCases) {
  std::mt19937_64 rng(20240611);
  double worst = 0;
  for (int i = 0; i < 100000; ++i) {
    expectMirrorMatches(test::randomSliceCase(rng), worst);
    if (HasFatalFailure()) return;
  }
  std::printf("[ info ] worst mirror error over 1e5 random cases: %.3g of scale x conditioning\n", worst);
}

TEST(Slicing, MirrorMatchesExactOnDegenerateCases) {
  double worst = 0;
  const auto cases = test::degenerateSliceCases();
  for (const SliceCase& c : cases) {
    expectMirrorMatches(c, worst);
    if (HasFatalFailure()) return;
  }
  std::printf("[ info ] worst mirror error over %zu degenerate cases: %.3g of scale x conditioning\n", cases.size(),
              worst);
}

// Zellmann & Lang's path walk (pathSlicePolygon) against the Rezk-Salama mirror: the same vertices bit for bit,
// drawn by the fan (vertex-lean) or in strip order by the strip (geometry program), tiling the same polygon.
void expectPathWalkMatches(const SliceCase& c) {
  const auto reference = rezkSalamaPolygon(c.boxMin, c.boxMax, c.n, c.d);
  const auto lean = pathSlicePolygon(c.boxMin, c.boxMax, c.n, c.d);
  const auto strip = pathSlicePolygon(c.boxMin, c.boxMax, c.n, c.d, true);
  const std::string fan = test::checkTiling(test::fanTriangles(lean), reference, c.n);
  ASSERT_EQ(fan, "") << test::caseText(c) << "\n  lean " << test::polygonText(lean) << "\n  mirror "
                     << test::polygonText(reference);
  const std::string zigzag = test::checkTiling(test::stripTriangles(strip), reference, c.n);
  ASSERT_EQ(zigzag, "") << test::caseText(c) << "\n  strip " << test::polygonText(strip) << "\n  mirror "
                        << test::polygonText(reference);
  for (size_t k = 0; k < 6; ++k) ASSERT_EQ(strip[k], lean[size_t(kSliceStrip[k])]) << test::caseText(c);
}

TEST(Slicing, PathWalkGivesTheMirrorsPolygonOnRandomCases) {
  std::mt19937_64 rng(31337);
  for (int i = 0; i < 100000 && !HasFatalFailure(); ++i) expectPathWalkMatches(test::randomSliceCase(rng));
}

TEST(Slicing, PathWalkGivesTheMirrorsPolygonOnDegenerateCases) {
  // Planes through corners, edges and faces, and just outside: repeats land elsewhere, the polygon is the same.
  for (const SliceCase& c : test::degenerateSliceCases()) {
    expectPathWalkMatches(c);
    if (HasFatalFailure()) return;
  }
}

TEST(Slicing, CornerPathsRunFromFrontToBackAlongEdges) {
  for (int front = 0; front < 8; ++front) {
    // A normal whose front corner is `front`: its distances grow along every path.
    const glm::dvec3 n(front & 1 ? -1.0 : 1.0, front & 2 ? -1.3 : 1.3, front & 4 ? -0.7 : 0.7);
    ASSERT_EQ(sliceFrontIndex(n.x, n.y, n.z), front);
    for (bool stripOrder : {false, true}) {
      const std::array<int, 24> paths = sliceCornerPaths(front, stripOrder);
      std::set<std::pair<int, int>> edges;
      for (int row = 0; row < 6; ++row) {
        EXPECT_EQ(paths[size_t(row * 4)], front);
        EXPECT_EQ(paths[size_t(row * 4 + 3)], front ^ 7);
        for (int k = 0; k < 3; ++k) {
          const int a = paths[size_t(row * 4 + k)], b = paths[size_t(row * 4 + k + 1)];
          const int diff = a ^ b;
          EXPECT_TRUE(diff == 1 || diff == 2 || diff == 4) << "front " << front << " row " << row;
          const glm::dvec3 pa(a & 1, (a >> 1) & 1, (a >> 2) & 1), pb(b & 1, (b >> 1) & 1, (b >> 2) & 1);
          EXPECT_GT(glm::dot(n, pb), glm::dot(n, pa)) << "front " << front << " row " << row;
          edges.insert({a, b});
        }
      }
      EXPECT_EQ(edges.size(), 12u) << "the six paths use each of the box's 12 edges";
    }
  }
}

// Vertices strictly inside an edge of the face x = faceX (y and z: one at a bound, one strictly between).
std::vector<glm::dvec3> faceEdgeVertices(std::span<const glm::dvec3> polygon, const glm::dvec3& lo,
                                         const glm::dvec3& hi, double faceX) {
  std::vector<glm::dvec3> out;
  for (const glm::dvec3& p : polygon) {
    if (p.x != faceX) continue;
    const bool yBound = p.y == lo.y || p.y == hi.y, zBound = p.z == lo.z || p.z == hi.z;
    if (yBound != zBound) out.push_back(p);
  }
  return out;
}

TEST(Slicing, MirrorGivesNeighboursBitIdenticalSharedVertices) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0, 1);
  int shared = 0;
  for (int i = 0; i < 20000; ++i) {
    SliceCase a = test::randomSliceCase(rng);
    SliceCase b = a;
    b.boxMin.x = a.boxMax.x;
    b.boxMax.x = a.boxMax.x + (a.boxMax.x - a.boxMin.x);
    // A plane through the shared face x = a.boxMax.x.
    double lo, hi;
    test::maxXFaceDistanceRange(a, lo, hi);
    a.d = b.d = lo + (hi - lo) * unit(rng);
    const auto pa = rezkSalamaPolygon(a.boxMin, a.boxMax, a.n, a.d);
    const auto pb = rezkSalamaPolygon(b.boxMin, b.boxMax, b.n, b.d);
    const auto fa = faceEdgeVertices(pa, a.boxMin, a.boxMax, a.boxMax.x);
    const auto fb = faceEdgeVertices(pb, b.boxMin, b.boxMax, b.boxMin.x);
    auto key = [](const glm::dvec3& p) { return std::make_tuple(p.x, p.y, p.z); };
    std::set<std::tuple<double, double, double>> sa, sb;
    for (const auto& p : fa) sa.insert(key(p));
    for (const auto& p : fb) sb.insert(key(p));
    ASSERT_EQ(sa, sb) << test::caseText(a) << " and its +x neighbour\n  " << test::polygonText(pa) << "\n  "
                      << test::polygonText(pb);
    shared += int(sa.size());
  }
  EXPECT_GT(shared, 20000);
}

TEST(Slicing, GlobalPlanesCoverExactlyTheCuttingPlanes) {
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int i = 0; i < 20000; ++i) {
    const SliceCase c = test::randomSliceCase(rng);
    const double extent = glm::length(c.boxMax - c.boxMin);
    const double step = extent * std::pow(10.0, -2 + 2.5 * unit(rng));
    const SlicePlanes planes = globalPlanes(c.boxMin, c.boxMax, c.n, step);
    const int front = sliceFrontIndex(c.n.x, c.n.y, c.n.z);
    auto corner = [&](int k) {
      return glm::dvec3(k & 1 ? c.boxMax.x : c.boxMin.x, k & 2 ? c.boxMax.y : c.boxMin.y,
                        k & 4 ? c.boxMax.z : c.boxMin.z);
    };
    const double dMin = glm::dot(c.n, corner(front)), dMax = glm::dot(c.n, corner(front ^ 7));
    const std::string where = test::caseText(c) + ", step " + std::to_string(step);
    ASSERT_GE(planes.count, 0) << where;
    ASSERT_EQ(planes.first, double(planes.firstIndex) * step) << where;
    // Inside: every listed plane; outside: the one before and the one after.
    ASSERT_GE(planes.distance(0), dMin) << where;
    ASSERT_LT(double(planes.firstIndex - 1) * step, dMin) << where;
    ASSERT_GE(planes.distance(planes.count), dMax) << where;
    if (planes.count > 0) {
      ASSERT_LT(planes.distance(planes.count - 1), dMax) << where;
    }
    for (int64_t k = 1; k < planes.count; ++k) ASSERT_GT(planes.distance(k), planes.distance(k - 1)) << where;
    // Every listed plane really cuts the box, except possibly one through the front corner alone.
    for (int64_t k = planes.count > 1 ? 1 : 0; k < planes.count; k += std::max<int64_t>(1, planes.count / 7)) {
      EXPECT_FALSE(intersectBoxPlane(c.boxMin, c.boxMax, c.n, planes.distance(k)).empty()) << where << " k " << k;
    }
  }
}

TEST(Slicing, BricksSharePlanesAndPartitionTheVolumeRange) {
  // Eight bricks tiling [0, 2]^3, viewed along +z: each plane is drawn by bricks of exactly one z layer.
  const glm::dvec3 n(0, 0, 1);
  const double step = 0.25;
  const SlicePlanes volume = globalPlanes(glm::dvec3(0), glm::dvec3(2), n, step);
  EXPECT_EQ(volume.firstIndex, 0);
  EXPECT_EQ(volume.count, 8);
  const PlaneIndexRange lower = planeIndexRange({0, 0, 0}, {1, 1, 1}, n, step);
  const PlaneIndexRange upper = planeIndexRange({1, 1, 1}, {2, 2, 2}, n, step);
  EXPECT_EQ(lower.begin, 0);
  EXPECT_EQ(lower.end, 4);
  EXPECT_EQ(upper.begin, 4);
  EXPECT_EQ(upper.end, 8);
  // Oblique: the union of the bricks' ranges is the volume's range, and planes are the same numbers everywhere.
  const glm::dvec3 oblique = glm::normalize(glm::dvec3(0.3, -0.5, 0.8));
  const SlicePlanes all = globalPlanes(glm::dvec3(0), glm::dvec3(2), oblique, 0.01);
  int64_t lo = INT64_MAX, hi = INT64_MIN;
  for (int b = 0; b < 8; ++b) {
    const glm::dvec3 origin(b & 1, (b >> 1) & 1, (b >> 2) & 1);
    const PlaneIndexRange range = planeIndexRange(origin, origin + 1.0, oblique, 0.01);
    lo = std::min(lo, range.begin);
    hi = std::max(hi, range.end);
  }
  EXPECT_EQ(lo, all.firstIndex);
  EXPECT_EQ(hi, all.firstIndex + all.count);
}

TEST(Slicing, RejectsBadInput) {
  const double nan = std::nan("");
  EXPECT_THROW(intersectBoxPlane(kUnitMin, kUnitMax, {0, 0, 0}, 0.5), RenderInputError);
  EXPECT_THROW(intersectBoxPlane({1, 0, 0}, {0, 1, 1}, {0, 0, 1}, 0.5), RenderInputError);
  EXPECT_THROW(intersectBoxPlane(kUnitMin, kUnitMax, {0, 0, 1}, nan), RenderInputError);
  EXPECT_THROW(rezkSalamaPolygon(kUnitMin, {1, nan, 1}, {0, 0, 1}, 0.5), RenderInputError);
  EXPECT_THROW(globalPlanes(kUnitMin, kUnitMax, {0, 0, 1}, 0), RenderInputError);
  EXPECT_THROW(globalPlanes(kUnitMin, kUnitMax, {0, 0, 1}, -1), RenderInputError);
  EXPECT_THROW(globalPlanes(kUnitMin, kUnitMax, {0, 0, 1}, 1e-300), RenderInputError);
  try {
    globalPlanes(kUnitMin, kUnitMax, {0, 0, 1}, -2);
  } catch (const RenderInputError& error) {
    EXPECT_NE(std::string(error.what()).find("-2"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace voxbrick::render
