// The exact box-plane polygon, the CPU mirrors of the GPU slicers' path walks, and the global slice planes.
#include "render/volume/Slicing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "render/core/RenderErrors.h"
#include "render/volume/SliceTables.h"

namespace voxbrick::render {

namespace {

std::string vectorText(const glm::dvec3& v) {
  return "(" + numberText(v.x) + ", " + numberText(v.y) + ", " + numberText(v.z) + ")";
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

void checkBoxAndNormal(const char* function, const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n) {
  if (!finite(boxMin) || !finite(boxMax) || boxMin.x > boxMax.x || boxMin.y > boxMax.y || boxMin.z > boxMax.z) {
    throw RenderInputError(std::string(function) + ": bad box " + vectorText(boxMin) + " - " + vectorText(boxMax));
  }
  if (!finite(n) || (n.x == 0 && n.y == 0 && n.z == 0)) {
    throw RenderInputError(std::string(function) + ": bad plane normal " + vectorText(n));
  }
}

// Corner c of the box by selection (bit 0 = x, bit 1 = y, bit 2 = z), as slicer.glsl's boxCorner.
glm::dvec3 boxCorner(const glm::dvec3& boxMin, const glm::dvec3& boxMax, int corner) {
  return {corner & 1 ? boxMax.x : boxMin.x, corner & 2 ? boxMax.y : boxMin.y, corner & 4 ? boxMax.z : boxMin.z};
}

// The point at `lambda` on the edge from corner `startCorner` to `endCorner`: only the coordinate along the edge is
// interpolated, as slicer.glsl's edgePoint does.
glm::dvec3 edgePoint(const glm::dvec3& boxMin, const glm::dvec3& boxMax, int startCorner, int endCorner,
                     double lambda) {
  const glm::dvec3 start = boxCorner(boxMin, boxMax, startCorner);
  const glm::dvec3 end = boxCorner(boxMin, boxMax, endCorner);
  glm::dvec3 vertex = start;
  for (int axis = 0; axis < 3; ++axis) {
    if ((startCorner ^ endCorner) & (1 << axis)) vertex[axis] = start[axis] * (1.0 - lambda) + end[axis] * lambda;
  }
  return vertex;
}

// Whether the plane at distance d crosses the edge from corner i to corner j (distances rising along it, d within
// them); if so, the vertex's edge and its parameter on it (clamped to [0, 1]) are set.
bool crossEdge(const double* cornerDistance, int i, int j, double d, int& startCorner, int& endCorner, double& lambda) {
  const double di = cornerDistance[i], dj = cornerDistance[j];
  if (!(di < dj && di <= d && d <= dj)) return false;
  startCorner = i;
  endCorner = j;
  lambda = std::clamp((d - di) / (dj - di), 0.0, 1.0);
  return true;
}

}  // namespace

std::vector<glm::dvec3> intersectBoxPlane(const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n,
                                          double d) {
  checkBoxAndNormal("intersectBoxPlane", boxMin, boxMax, n);
  if (!std::isfinite(d)) throw RenderInputError("intersectBoxPlane: bad plane distance " + numberText(d));

  glm::dvec3 corners[8];
  double side[8];  // signed distance to the plane, times |n|
  for (int c = 0; c < 8; ++c) {
    corners[c] = boxCorner(boxMin, boxMax, c);
    side[c] = glm::dot(n, corners[c]) - d;
  }
  std::vector<glm::dvec3> points;
  for (int c = 0; c < 8; ++c) {
    if (side[c] == 0) points.push_back(corners[c]);
  }
  for (int c = 0; c < 8; ++c) {
    for (int axis = 0; axis < 3; ++axis) {
      const int other = c | (1 << axis);
      if (other == c) continue;
      if ((side[c] < 0 && side[other] > 0) || (side[c] > 0 && side[other] < 0)) {
        // Only one coordinate varies along a box edge, so only that one is interpolated.
        glm::dvec3 p = corners[c];
        const double t = side[c] / (side[c] - side[other]);
        p[axis] = corners[c][axis] + t * (corners[other][axis] - corners[c][axis]);
        points.push_back(p);
      }
    }
  }

  const glm::dvec3 absMin = glm::abs(boxMin), absMax = glm::abs(boxMax);
  const double scale = std::max({absMin.x, absMin.y, absMin.z, absMax.x, absMax.y, absMax.z,
                                 glm::length(boxMax - boxMin), std::numeric_limits<double>::min()});
  const double mergeDistance = 64 * std::numeric_limits<double>::epsilon() * scale;
  std::vector<glm::dvec3> merged;
  for (const glm::dvec3& p : points) {
    const bool duplicate = std::any_of(merged.begin(), merged.end(),
                                       [&](const glm::dvec3& q) { return glm::length(p - q) <= mergeDistance; });
    if (!duplicate) merged.push_back(p);
  }
  if (merged.size() < 3) return {};

  // Sort by angle about the centroid in a plane basis (e1, e2) with e1 x e2 = -n: counter-clockwise seen along +n.
  const glm::dvec3 unitN = glm::normalize(n);
  const glm::dvec3 helper = std::abs(unitN.x) < 0.5 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 e1 = glm::normalize(glm::cross(helper, unitN));
  const glm::dvec3 e2 = glm::cross(e1, unitN);
  glm::dvec3 centroid(0);
  for (const glm::dvec3& p : merged) centroid += p;
  centroid /= double(merged.size());
  auto angle = [&](const glm::dvec3& p) { return std::atan2(glm::dot(p - centroid, e2), glm::dot(p - centroid, e1)); };
  std::sort(merged.begin(), merged.end(),
            [&](const glm::dvec3& a, const glm::dvec3& b) { return angle(a) < angle(b); });
  return merged;
}

std::array<glm::dvec3, 6> rezkSalamaPolygon(const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n,
                                            double d) {
  checkBoxAndNormal("rezkSalamaPolygon", boxMin, boxMax, n);
  if (!std::isfinite(d)) throw RenderInputError("rezkSalamaPolygon: bad plane distance " + numberText(d));

  // Line for line as slice.vert.glsl's main(), in double precision; see the comments there.
  const int front = sliceFrontIndex(n.x, n.y, n.z);
  double cornerDistance[8];
  for (int corner = 0; corner < 8; ++corner) cornerDistance[corner] = glm::dot(n, boxCorner(boxMin, boxMax, corner));

  std::array<glm::dvec3, 6> polygon;
  for (int polygonVertex = 0; polygonVertex < 6; ++polygonVertex) {
    int startCorner = front;
    int endCorner = front;
    double lambda = 0;
    if (cornerDistance[front] <= d && d < cornerDistance[front ^ 7]) {
      for (int e = 0; e < 4; ++e) {
        const int i = kSliceSequence[front * 8 + kSliceEdgeStart[polygonVertex * 4 + e]];
        const int j = kSliceSequence[front * 8 + kSliceEdgeEnd[polygonVertex * 4 + e]];
        if (crossEdge(cornerDistance, i, j, d, startCorner, endCorner, lambda)) break;
      }
    }
    polygon[size_t(polygonVertex)] = edgePoint(boxMin, boxMax, startCorner, endCorner, lambda);
  }
  return polygon;
}

std::array<glm::dvec3, 6> pathSlicePolygon(const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n,
                                           double d, bool stripOrder) {
  checkBoxAndNormal("pathSlicePolygon", boxMin, boxMax, n);
  if (!std::isfinite(d)) throw RenderInputError("pathSlicePolygon: bad plane distance " + numberText(d));

  // As the programs walk their paths (slicer.glsl's crossPath), in double precision.
  const std::array<int, 24> paths = sliceCornerPaths(sliceFrontIndex(n.x, n.y, n.z), stripOrder);
  double cornerDistance[8];
  for (int corner = 0; corner < 8; ++corner) cornerDistance[corner] = glm::dot(n, boxCorner(boxMin, boxMax, corner));
  const int front = paths[0], back = paths[3];

  std::array<glm::dvec3, 6> polygon;
  for (size_t row = 0; row < 6; ++row) {
    int startCorner = front;
    int endCorner = front;
    double lambda = 0;
    if (cornerDistance[front] <= d && d < cornerDistance[back]) {
      for (size_t e = 0; e < 3; ++e)
        if (crossEdge(cornerDistance, paths[row * 4 + e], paths[row * 4 + e + 1], d, startCorner, endCorner, lambda))
          break;
    }
    polygon[row] = edgePoint(boxMin, boxMax, startCorner, endCorner, lambda);
  }
  return polygon;
}

double polygonArea(std::span<const glm::dvec3> polygon, const glm::dvec3& n) {
  if (polygon.size() < 3) return 0;
  // Relative to the first vertex, so that far-from-origin polygons keep their precision.
  glm::dvec3 sum(0);
  for (size_t i = 1; i + 1 < polygon.size(); ++i) {
    sum += glm::cross(polygon[i] - polygon[0], polygon[i + 1] - polygon[0]);
  }
  return -0.5 * glm::dot(sum, glm::normalize(n));
}

PlaneIndexRange planeIndexRange(const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n, double step) {
  checkBoxAndNormal("planeIndexRange", boxMin, boxMax, n);
  if (!(step > 0) || !std::isfinite(step)) throw RenderInputError("planeIndexRange: bad step " + numberText(step));
  const int front = sliceFrontIndex(n.x, n.y, n.z);
  const double dMin = glm::dot(n, boxCorner(boxMin, boxMax, front));
  const double dMax = glm::dot(n, boxCorner(boxMin, boxMax, front ^ 7));
  constexpr double kLimit = 9007199254740992.0;  // 2^53: beyond it k * step no longer names distinct planes
  if (!(std::abs(dMin / step) < kLimit && std::abs(dMax / step) < kLimit)) {
    throw RenderInputError("planeIndexRange: step " + numberText(step) + " is too small for distances " +
                           numberText(dMin) + " to " + numberText(dMax));
  }
  // ceil() of a rounded quotient can be one off; settle on exactly the k with dMin <= k * step < dMax.
  auto firstAtLeast = [step](double distance) {
    auto k = int64_t(std::ceil(distance / step));
    while (double(k - 1) * step >= distance) --k;
    while (double(k) * step < distance) ++k;
    return k;
  };
  PlaneIndexRange range;
  range.begin = firstAtLeast(dMin);
  range.end = std::max(range.begin, firstAtLeast(dMax));
  return range;
}

PlaneIndexRange slicerPlaneRange(const glm::dvec3& boxMin, const glm::dvec3& boxMax, const glm::dvec3& n, double step) {
  PlaneIndexRange range = planeIndexRange(boxMin, boxMax, n, step);
  range.begin -= 1;
  range.end += 1;
  return range;
}

SlicePlanes globalPlanes(const glm::dvec3& volumeMin, const glm::dvec3& volumeMax, const glm::dvec3& n, double step) {
  const PlaneIndexRange range = planeIndexRange(volumeMin, volumeMax, n, step);
  SlicePlanes planes;
  planes.firstIndex = range.begin;
  planes.count = range.count();
  planes.step = step;
  planes.first = double(range.begin) * step;
  return planes;
}

}  // namespace voxbrick::render
