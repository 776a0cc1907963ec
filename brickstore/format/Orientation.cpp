// Index-to-world transforms read from files: unit axes and spacing from the voxel step vectors, shear checks, and
// the axis letters `voxbrick info` prints.
#include "brickstore/format/Orientation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

using Vec = Orientation::Vec;

double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double length(const Vec& a) { return std::sqrt(dot(a, a)); }

std::string vecText(const Vec& v) {
  char text[96];
  std::snprintf(text, sizeof text, "(%.6g, %.6g, %.6g)", v[0], v[1], v[2]);
  return text;
}

bool finite(const Vec& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// Removes from `v` its component along the unit vector `u`.
void removeComponent(Vec& v, const Vec& u) {
  const double c = dot(v, u);
  for (int a = 0; a < 3; ++a) v[a] -= c * u[a];
}

}  // namespace

Orientation fromDirections(const Directions& d, const std::string& what, Vec3d& spacing) {
  if (!finite(d.origin)) throw InputError(what + ": origin " + vecText(d.origin) + " is not finite");
  Orientation o;
  o.origin = d.origin;
  o.patient = d.patient;
  double lengths[3];
  for (int a = 0; a < 3; ++a) {
    const Vec& c = d.columns[a];
    lengths[a] = length(c);
    if (!finite(c) || !(lengths[a] > 0) || !std::isfinite(lengths[a]))
      throw InputError(what + ": the direction of index axis " + "ijk"[a] + std::string(" ") + vecText(c) +
                       " is not a finite non-zero vector");
    for (int b = 0; b < 3; ++b) o.axes[a][b] = c[b] / lengths[a];
  }
  // Shear: the largest deviation of a pair's angle from 90 degrees.
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3;
    const double deviation = std::abs(std::asin(std::min(1.0, std::abs(dot(o.axes[a], o.axes[b])))));
    if (deviation > kShearTolerance)
      throw InputError(what + ": index axes " + "ijk"[std::min(a, b)] + std::string(" and ") + "ijk"[std::max(a, b)] +
                       " are " + std::to_string(90.0 - deviation * 180.0 / M_PI) +
                       " degrees apart, not 90: a sheared grid is not supported (resample the volume first)");
  }
  removeComponent(o.axes[1], o.axes[0]);
  removeComponent(o.axes[2], o.axes[0]);
  removeComponent(o.axes[2], o.axes[1]);
  for (Vec& axis : o.axes) {
    const double l = length(axis);
    for (double& x : axis) x /= l;
  }
  spacing = Vec3d{lengths[0], lengths[1], lengths[2]};
  return o;
}

std::string axesLetters(const Orientation& o) {
  static const char kPositive[] = "RAS", kNegative[] = "LPI";
  std::string letters;
  for (const Vec& axis : o.axes) {
    int dominant = 0;
    for (int b = 1; b < 3; ++b)
      if (std::abs(axis[b]) > std::abs(axis[dominant])) dominant = b;
    if (std::abs(axis[dominant]) < 1 - 1e-4) return "oblique";
    letters += axis[dominant] > 0 ? kPositive[dominant] : kNegative[dominant];
  }
  return letters;
}

std::string orientationText(const Orientation& o) {
  return axesLetters(o) + ", origin " + vecText(o.origin) + (o.patient ? "" : ", no patient frame");
}

}  // namespace voxbrick::store
