// The emission–absorption integral of one ray segment over which the normalised value runs linearly: the closed forms
// the pre-integration table and the tetrahedral reference share.
//
// Along the segment the value runs from sf to sb over r reference lengths; the transfer function is linear in the
// value between its control points, so the segment falls into pieces on each of which colour and alpha are linear in
// the position y in [0, 1] across the piece. On a piece with extinction k(y) = -ln(1 - a(y)) and optical depth
// tau(y) = r' Int_0^y k (r' the piece's reference lengths), the transmittance T = exp(-tau) is closed form
// (meanExtinction), and integrating the premultiplied colour C = Int rgb dP (P = 1 - T) by parts, with rgb linear,
// gives exactly
//   C = rgb_entry (1 - m) + rgb_exit (m - T(1)),   m = Int_0^1 T(y) dy, the mean transmittance.
// m is the only quantity without a closed form (b^(cb) e^(-cb) has no elementary antiderivative): the table models it
// cheaply (PreIntegration.cpp), integrateSegment integrates it to round-off.
#pragma once

#include <vector>

#include <glm/glm.hpp>

#include "render/core/TransferFunction.h"

namespace voxbrick::render {

/// Premultiplied colour and transmittance of a stretch of a ray.
struct RaySpan {
  glm::dvec3 color{0.0};
  double transmittance = 1;
};

/// `front` then `back`, front to back (associative).
inline RaySpan over(const RaySpan& front, const RaySpan& back) {
  return {front.color + front.transmittance * back.color, front.transmittance * back.transmittance};
}

/// A linear piece crossed from colour `entry` to colour `exit` (straight), with transmittance `transmittance` over
/// the whole piece and mean transmittance `mean` over it: the by-parts identity above.
inline RaySpan crossLinearPiece(const glm::dvec3& entry, const glm::dvec3& exit, double transmittance, double mean) {
  return {entry * (1 - mean) + exit * (mean - transmittance), transmittance};
}

/// The mean of -ln(1 - a) over a running linearly from a0 to a1 (both in [0, 1]); infinite only if both are 1.
double meanExtinction(double a0, double a1);

/// The transfer function's linear formula on the open interval of values around m, evaluated at s (clamped to the
/// interval's ends; constant outside the first and last control points). At a step (two points at one x) each side
/// keeps its own value, so a piece between two cuts is classified by its own formula at both ends.
glm::dvec4 linearAround(const std::vector<TransferFunction::Point>& points, double m, double s);

/// The mean transmittance m = Int_0^1 exp(-tau(y)) dy of a piece whose alpha runs linearly from a0 to a1 (in
/// [0, 1]) over `ratio` reference lengths, tau(y) = ratio * y * meanExtinction(a0, a(y)) in closed form. Adaptive
/// 8-point Gauss–Legendre on the exact integrand, to an absolute error below 1e-14 (logarithmic singularities where
/// an alpha is 1 are refined like the rest); closed form when a0 == a1.
double meanTransmittance(double a0, double a1, double ratio);

/// The segment of `ratio` reference lengths over which the normalised value runs linearly from sf (front) to sb
/// (back): premultiplied rgb and opacity, the integral of the optical model (ARCHITECTURE.md) in its continuous limit
/// with the transfer function exactly as TransferFunction::evaluate defines it (values outside [0, 1] read as its
/// ends, which is the value window's clamp; steps at control points; NaN reads as 0). Cut at every control point
/// the value crosses; each piece's opacity is closed form, its colour exact up to meanTransmittance's 1e-14. sf ==
/// sb gives post-classification's closed form (c * A, A = 1 - (1 - a)^ratio); ratio <= 0 (or NaN) gives 0.
glm::dvec4 integrateSegment(const TransferFunction& tf, double sf, double sb, double ratio);

}  // namespace voxbrick::render
