// What the tetrahedral reference is checked against, computed independently of it: brute-force integration along a
// ray, the single segment of a linear field, pixel rays from the camera's definition, and cameras around a box.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "TetMeshes.h"
#include "render/RenderFixtures.h"
#include "render/core/Scene.h"
#include "render/core/SegmentIntegral.h"
#include "render/reference/Compositing.h"
#include "render/reference/TetReference.h"

namespace voxbrick::test {

using render::Box;
using render::CameraSpec;
using render::FrontToBack;
using render::TetReferenceParams;
using render::TransferFunction;

/// The model along o + t d over [t0, t1] by the midpoint rule with about n * refine substeps, cut where the normalised
/// value (linear along the ray) crosses a control point or an end of the window, so that each piece is smooth.
inline glm::dvec4 bruteForce(const TetReferenceParams& p, const Field& field, const glm::dvec3& o, const glm::dvec3& d,
                             double t0, double t1, int n, int refine = 1) {
  auto value = [&](double t) { return (field(o + t * d) - p.windowLo) / (p.windowHi - p.windowLo); };
  const double v0 = value(t0), v1 = value(t1);
  std::vector<double> cuts{0.0, 1.0};
  std::vector<double> kinks{0.0, 1.0};
  for (const TransferFunction::Point& q : p.transferFunction.points()) kinks.push_back(q.x);
  for (double x : kinks)
    if (v0 != v1 && (x - v0) / (v1 - v0) > 0 && (x - v0) / (v1 - v0) < 1) cuts.push_back((x - v0) / (v1 - v0));
  std::sort(cuts.begin(), cuts.end());
  FrontToBack<double> acc;
  for (size_t i = 0; i + 1 < cuts.size(); ++i) {
    const double u0 = cuts[i], length = cuts[i + 1] - cuts[i];
    const int steps = std::max(4, int(std::ceil(n * length))) * refine;
    const double h = length * (t1 - t0) / steps;
    for (int j = 0; j < steps; ++j) {
      const double t = t0 + (u0 + (j + 0.5) / steps * length) * (t1 - t0);
      const glm::dvec4 c = p.transferFunction.evaluate(std::clamp(value(t), 0.0, 1.0));
      acc.add(c.r, c.g, c.b, TransferFunction::correctOpacity(c.a, h / p.referenceLength));
    }
  }
  return {acc.r, acc.g, acc.b, acc.a};
}

/// The single segment of a linear field along [t0, t1]: what a mesh of that field must composite to along the ray.
inline glm::dvec4 oneSegment(const TetReferenceParams& p, const Field& field, const glm::dvec3& o, const glm::dvec3& d,
                             double t0, double t1) {
  const double w = p.windowHi - p.windowLo;
  return render::integrateSegment(p.transferFunction, (field(o + t0 * d) - p.windowLo) / w,
                                  (field(o + t1 * d) - p.windowLo) / w, (t1 - t0) / p.referenceLength);
}

/// Cameras around `box`: oblique perspective, along z from both sides, orthographic from below, the eye inside.
inline std::vector<std::pair<std::string, CameraSpec>> cameras(const Box& box) {
  std::vector<std::pair<std::string, CameraSpec>> out;
  CameraSpec oblique;
  oblique.azimuth = 35, oblique.elevation = 25, oblique.distance = 2.2;
  out.push_back({"oblique", oblique});
  CameraSpec axis;
  axis.orbit = false;
  axis.center = box.center();
  axis.eye = box.center() + glm::dvec3(0, 0, 4 * box.radius());
  out.push_back({"axis", axis});
  axis.eye.z = box.center().z - 4 * box.radius();
  out.push_back({"axis-back", axis});
  CameraSpec ortho = oblique;
  ortho.orthographic = true;
  ortho.azimuth = 200, ortho.elevation = -40;
  out.push_back({"ortho", ortho});
  CameraSpec inside = oblique;
  inside.distance = 0.25, inside.fovY = 75;
  out.push_back({"inside", inside});
  return out;
}

/// The perspective camera's pixel ray as Camera and the grid reference define it, computed here independently.
inline glm::dvec3 perspectiveDirection(const TetReferenceParams& p, int x, int y) {
  const glm::dvec3 forward = p.camera.viewDirection();
  const glm::dvec3 right = glm::normalize(glm::cross(forward, p.camera.upVector()));
  const glm::dvec3 up = glm::cross(right, forward);
  const double t = std::tan(0.5 * glm::radians(p.camera.fovYDegrees)), aspect = double(p.width) / p.height;
  const double sx = 2.0 * (x + 0.5) / p.width - 1, sy = 1 - 2.0 * (y + 0.5) / p.height;
  return glm::normalize(forward + sx * t * aspect * right + sy * t * up);
}

}  // namespace voxbrick::test
