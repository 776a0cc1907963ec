// Test helpers for the slicers: random and degenerate box/plane cases, the comparison of a Rezk-Salama polygon (six
// vertices with repeats) with the exact one, and of a slicer's triangles with another's polygon, shared by the
// CPU-mirror and the GLSL tests.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "render/volume/SliceTables.h"
#include "render/volume/Slicing.h"

namespace voxbrick::test {

/// One box and one plane dot(n, x) = d.
struct SliceCase {
  glm::dvec3 boxMin{0};
  glm::dvec3 boxMax{1};
  glm::dvec3 n{0, 0, 1};
  double d = 0.5;
};

inline std::string vec3Text(const glm::dvec3& v) {
  char text[96];
  std::snprintf(text, sizeof(text), "(%.17g, %.17g, %.17g)", v.x, v.y, v.z);
  return text;
}

// Strings here are appended piece by piece: GCC 12 warns falsely (-Wrestrict, bug 105651) on "literal" + string.
inline std::string caseText(const SliceCase& c) {
  char d[32];
  std::snprintf(d, sizeof(d), "%.17g", c.d);
  std::string text = "box ";
  text += vec3Text(c.boxMin);
  text += " - ";
  text += vec3Text(c.boxMax);
  text += ", n ";
  text += vec3Text(c.n);
  text += ", d ";
  text += d;
  return text;
}

inline std::string polygonText(std::span<const glm::dvec3> polygon) {
  std::string text = "[";
  for (const glm::dvec3& p : polygon) {
    text += ' ';
    text += vec3Text(p);
  }
  text += " ]";
  return text;
}

/// The length scale float or double round-off is relative to: the largest coordinate or extent involved.
inline double caseScale(const SliceCase& c) {
  const glm::dvec3 a = glm::abs(c.boxMin), b = glm::abs(c.boxMax), e = c.boxMax - c.boxMin;
  return std::max({a.x, a.y, a.z, b.x, b.y, b.z, e.x, e.y, e.z, std::abs(c.d) / glm::length(c.n)});
}

/// How much round-off in the plane distance moves the exact polygon's vertices: a vertex on an edge along axis a
/// slides |n| / |n[a]| times as far as the plane moves. The largest such factor over the polygon, at least 1.
inline double edgeConditioning(const std::vector<glm::dvec3>& exact, const SliceCase& c) {
  double worst = 1;
  for (const glm::dvec3& p : exact) {
    for (int axis = 0; axis < 3; ++axis) {
      const bool atBound = p[axis] == c.boxMin[axis] || p[axis] == c.boxMax[axis];
      if (!atBound && c.n[axis] != 0) worst = std::max(worst, glm::length(c.n) / std::abs(c.n[axis]));
    }
  }
  return worst;
}

/// The exact polygon as the slicer should draw it: intersectBoxPlane, except that boxes are half-open along n, so a
/// plane at or past the back corner's distance gives nothing. That distance is computed as the slicer computes it:
/// in double for the CPU mirror, in float (inputs already rounded to float) for the shader.
inline std::vector<glm::dvec3> expectedSlice(const SliceCase& c, bool inFloat = false) {
  const int back = 7 ^ ((c.n.x < 0 ? 1 : 0) | (c.n.y < 0 ? 2 : 0) | (c.n.z < 0 ? 4 : 0));
  const glm::dvec3 backCorner(back & 1 ? c.boxMax.x : c.boxMin.x, back & 2 ? c.boxMax.y : c.boxMin.y,
                              back & 4 ? c.boxMax.z : c.boxMin.z);
  const double backDistance =
      inFloat ? double(glm::dot(glm::vec3(c.n), glm::vec3(backCorner))) : glm::dot(c.n, backCorner);
  if (c.d >= backDistance) return {};
  return render::intersectBoxPlane(c.boxMin, c.boxMax, c.n, c.d);
}

/// A random case with a given normal: box size log-uniform over 1e-2..1e2 with aspect up to 1:20, placed within 8
/// sizes of the origin (as bricks of a volume are), and d from 10% before the front corner to 10% past the back one
/// (so about one plane in six misses).
inline SliceCase randomSliceCase(std::mt19937_64& rng, const glm::dvec3& n) {
  std::uniform_real_distribution<double> unit(0, 1);
  SliceCase c;
  c.n = n;
  const double size = std::pow(10.0, -2 + 4 * unit(rng));
  glm::dvec3 extent;
  for (int i = 0; i < 3; ++i) extent[i] = size * (0.05 + 0.95 * unit(rng));
  for (int i = 0; i < 3; ++i) c.boxMin[i] = size * (16 * unit(rng) - 8);
  c.boxMax = c.boxMin + extent;
  double lo = 1e300, hi = -1e300;
  for (int k = 0; k < 8; ++k) {
    const glm::dvec3 p{k & 1 ? c.boxMax.x : c.boxMin.x, k & 2 ? c.boxMax.y : c.boxMin.y,
                       k & 4 ? c.boxMax.z : c.boxMin.z};
    lo = std::min(lo, glm::dot(c.n, p));
    hi = std::max(hi, glm::dot(c.n, p));
  }
  c.d = lo + (hi - lo) * (1.2 * unit(rng) - 0.1);
  return c;
}

/// A uniformly distributed random unit normal.
/// The range of plane distances dot(n, x) over the face x = c.boxMax.x (which a +x neighbour shares), so that a
/// plane through that face can be chosen.
inline void maxXFaceDistanceRange(const SliceCase& c, double& lo, double& hi) {
  lo = 1e300, hi = -1e300;
  for (int corner = 0; corner < 4; ++corner) {
    const double v = glm::dot(
        c.n, glm::dvec3(c.boxMax.x, corner & 1 ? c.boxMax.y : c.boxMin.y, corner & 2 ? c.boxMax.z : c.boxMin.z));
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
}

inline glm::dvec3 randomNormal(std::mt19937_64& rng) {
  std::normal_distribution<double> gauss(0, 1);
  glm::dvec3 n;
  do {
    n = {gauss(rng), gauss(rng), gauss(rng)};
  } while (glm::length(n) < 1e-3);
  return glm::normalize(n);
}

/// A random case with a random normal.
inline SliceCase randomSliceCase(std::mt19937_64& rng) {
  const glm::dvec3 n = randomNormal(rng);
  return randomSliceCase(rng, n);
}

/// Degenerate cases: views along the axes, the face diagonals and the space diagonals (both signs); unit boxes,
/// boxes of extent 1e-6 and 1e6, and a thin one; planes through every corner, through the middle, a quarter in, and
/// just outside either end (by 1e-9 of the extent).
inline std::vector<SliceCase> degenerateSliceCases() {
  std::vector<glm::dvec3> normals;
  for (int axis = 0; axis < 3; ++axis) {
    for (double sign : {1.0, -1.0}) {
      glm::dvec3 n(0);
      n[axis] = sign;
      normals.push_back(n);
    }
  }
  for (int a = 0; a < 3; ++a) {
    for (double s1 : {1.0, -1.0}) {
      for (double s2 : {1.0, -1.0}) {
        glm::dvec3 n(0);
        n[a] = s1;
        n[(a + 1) % 3] = s2;
        normals.push_back(glm::normalize(n));
      }
    }
  }
  for (int signs = 0; signs < 8; ++signs) {
    normals.push_back(glm::normalize(glm::dvec3(signs & 1 ? -1 : 1, signs & 2 ? -1 : 1, signs & 4 ? -1 : 1)));
  }
  const std::vector<std::pair<glm::dvec3, glm::dvec3>> boxes = {
      {{0, 0, 0}, {1, 1, 1}},
      {{-0.5, 2, -3}, {0.5, 3.5, -1}},
      {{1e-6, -2e-6, 0.5e-6}, {2e-6, -1e-6, 1.5e-6}},
      {{-1e6, -2e6, -0.5e6}, {1e6, -1e6, 0.5e6}},
      {{0, 0, 0}, {1, 1, 1e-3}},
  };
  std::vector<SliceCase> cases;
  for (const auto& [lo, hi] : boxes) {
    for (const glm::dvec3& n : normals) {
      std::vector<double> distances;
      double first = 1e300, last = -1e300;
      for (int k = 0; k < 8; ++k) {
        const glm::dvec3 p{k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z};
        distances.push_back(glm::dot(n, p));
        first = std::min(first, distances.back());
        last = std::max(last, distances.back());
      }
      const double margin = 1e-9 * (last - first);
      for (double d : {0.5 * (first + last), 0.75 * first + 0.25 * last, first - margin, last + margin}) {
        distances.push_back(d);
      }
      for (double d : distances) cases.push_back({lo, hi, n, d});
    }
  }
  return cases;
}

/// Outcome of comparing a Rezk-Salama polygon with the exact one.
struct PolygonCheck {
  std::string failure;  ///< empty when they agree
  double error = 0;     ///< Hausdorff distance of the vertex sets; for a sliver, the area difference / perimeter
};

/// `got` (six vertices with repeats, from the mirror or the shader) against `exact` (intersectBoxPlane): after
/// merging repeats closer than `tol`, the vertex sets are within `tol` of each other both ways, `got` is convex and
/// counter-clockwise seen along +n (no vertex more than `tol` inside the chord of its neighbours), and the areas
/// agree within 2 * tol * perimeter. When the exact polygon is empty or narrower than tol, only the areas are
/// compared, within the same bound.
inline PolygonCheck checkPolygon(std::span<const glm::dvec3> got, const std::vector<glm::dvec3>& exact,
                                 const glm::dvec3& n, double tol) {
  PolygonCheck check;
  auto mergeRepeats = [tol](std::span<const glm::dvec3> polygon) {
    std::vector<glm::dvec3> merged;
    for (const glm::dvec3& p : polygon) {
      if (merged.empty() || glm::length(p - merged.back()) > tol) merged.push_back(p);
    }
    while (merged.size() > 1 && glm::length(merged.back() - merged.front()) <= tol) merged.pop_back();
    return merged;
  };
  const std::vector<glm::dvec3> merged = mergeRepeats(got);
  // An exact polygon narrower than tol (a plane grazing a corner or an edge) counts as empty: within round-off the
  // plane may miss the box, and then the slicer may put its empty polygon anywhere.
  const std::vector<glm::dvec3> exactMerged = mergeRepeats(exact);

  auto perimeter = [](std::span<const glm::dvec3> polygon) {
    double sum = 0;
    for (size_t i = 0; i < polygon.size(); ++i) sum += glm::length(polygon[(i + 1) % polygon.size()] - polygon[i]);
    return sum;
  };
  // Area and perimeter on the raw vertices (repeats add nothing); merged only for the convexity test.
  const double gotArea = render::polygonArea(got, n);
  if (exactMerged.size() < 3) {
    // The area difference over the perimeter: how much wider one sliver is than the other.
    const double exactArea = exact.size() >= 3 ? render::polygonArea(exact, n) : 0.0;
    const double length = std::max({perimeter(got), exact.size() >= 3 ? perimeter(exact) : 0.0, tol});
    check.error = std::abs(gotArea - exactArea) / length;
    if (check.error > 2 * tol) {
      check.failure = "exact polygon is empty or narrower than tol, but got area " + std::to_string(gotArea);
    }
    return check;
  }

  auto farthestNearest = [](std::span<const glm::dvec3> from, std::span<const glm::dvec3> to) {
    double worst = 0;
    for (const glm::dvec3& p : from) {
      double nearest = 1e300;
      for (const glm::dvec3& q : to) nearest = std::min(nearest, glm::length(p - q));
      worst = std::max(worst, nearest);
    }
    return worst;
  };
  // On the raw vertices: repeats do not change a Hausdorff distance, and merging would blur it by up to tol.
  check.error = std::max(farthestNearest(got, exact), farthestNearest(exact, got));
  if (check.error > tol) {
    check.failure = "vertex sets differ by " + std::to_string(check.error) + " > tol " + std::to_string(tol);
    return check;
  }
  const glm::dvec3 towardViewer = -glm::normalize(n);
  for (size_t i = 0; merged.size() >= 3 && i < merged.size(); ++i) {
    const glm::dvec3& a = merged[i];
    const glm::dvec3& b = merged[(i + 1) % merged.size()];
    const glm::dvec3& c = merged[(i + 2) % merged.size()];
    const double chord = glm::length(c - a);
    if (chord <= tol) continue;
    // In a convex polygon running counter-clockwise about towardViewer, b bulges out past the chord from a to c.
    const double outward = glm::dot(glm::cross(b - a, c - a), towardViewer) / chord;
    if (outward < -tol) {
      check.failure = "not convex and counter-clockwise: vertex " + std::to_string((i + 1) % merged.size()) + " lies " +
                      std::to_string(-outward) + " inside the chord of its neighbours";
      return check;
    }
  }
  const double exactArea = render::polygonArea(exact, n);
  const double areaTol = 2 * tol * perimeter(exact) + tol * tol;
  if (std::abs(gotArea - exactArea) > areaTol) {
    check.failure = "area " + std::to_string(gotArea) + " != exact " + std::to_string(exactArea);
  }
  return check;
}

/// One triangle as a slicer draws it.
using Triangle = std::array<glm::dvec3, 3>;

/// The triangles of a fan of six polygon vertices drawn through kSliceFan (P0..P5 with repeats).
inline std::vector<Triangle> fanTriangles(std::span<const glm::dvec3> polygon) {
  std::vector<Triangle> out;
  for (size_t k = 0; k + 2 < render::kSliceFan.size(); k += 3) {
    out.push_back({polygon[size_t(render::kSliceFan[k])], polygon[size_t(render::kSliceFan[k + 1])],
                   polygon[size_t(render::kSliceFan[k + 2])]});
  }
  return out;
}

/// The triangles of a triangle strip, each in the order that keeps the strip's winding (odd ones swapped, as GL
/// rasterises them).
inline std::vector<Triangle> stripTriangles(std::span<const glm::dvec3> strip) {
  std::vector<Triangle> out;
  for (size_t i = 0; i + 2 < strip.size(); ++i) {
    if (i % 2 == 0)
      out.push_back({strip[i], strip[i + 1], strip[i + 2]});
    else
      out.push_back({strip[i + 1], strip[i], strip[i + 2]});
  }
  return out;
}

/// Whether `triangles` (a slicer's drawing of one plane through one box) tile the polygon `reference` (six vertices
/// with repeats, from another slicer): the same distinct vertices bit for bit, no triangle clockwise seen along +n
/// (beyond round-off), and their areas adding up to the polygon's, so that they neither overlap nor leave a hole.
/// Drawing nothing is right for a polygon of no area only. Empty when they do; otherwise what is wrong.
inline std::string checkTiling(const std::vector<Triangle>& triangles, std::span<const glm::dvec3> reference,
                               const glm::dvec3& n) {
  auto bits = [](const glm::dvec3& p) { return std::array<double, 3>{p.x, p.y, p.z}; };
  std::vector<std::array<double, 3>> want, got;
  for (const glm::dvec3& p : reference) want.push_back(bits(p));
  for (const Triangle& t : triangles)
    for (const glm::dvec3& p : t) got.push_back(bits(p));
  std::sort(want.begin(), want.end());
  want.erase(std::unique(want.begin(), want.end()), want.end());
  std::sort(got.begin(), got.end());
  got.erase(std::unique(got.begin(), got.end()), got.end());

  double perimeter = 0;
  for (size_t i = 0; i < reference.size(); ++i)
    perimeter += glm::length(reference[(i + 1) % reference.size()] - reference[i]);
  const double area = render::polygonArea(reference, n);
  // Both sums are exact but for double round-off; a misplaced triangle is off by its own area.
  const double areaTolerance = 1e-9 * perimeter * perimeter;
  if (triangles.empty()) {
    return std::abs(area) <= areaTolerance ? "" : "nothing drawn for a polygon of area " + std::to_string(area);
  }
  if (got != want) {
    return "the distinct vertices differ: " + std::to_string(got.size()) + " drawn, " + std::to_string(want.size()) +
           " in the polygon";
  }
  double sum = 0;
  for (const Triangle& t : triangles) {
    const double a = render::polygonArea(t, n);
    if (a < -areaTolerance) return "a triangle runs clockwise (area " + std::to_string(a) + ")";
    sum += a;
  }
  if (std::abs(sum - area) > areaTolerance) {
    return "the triangles' areas add up to " + std::to_string(sum) + ", the polygon's is " + std::to_string(area);
  }
  return "";
}

}  // namespace voxbrick::test
