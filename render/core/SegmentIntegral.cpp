// Segment integrals: closed-form optical depth per linear piece of the transfer function, the mean transmittance by
// adaptive Gauss–Legendre quadrature of its exact integrand.
#include "render/core/SegmentIntegral.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace voxbrick::render {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

/// The 8-point Gauss–Legendre rule on [-1, 1]: nodes +-kNodes[i], weights kWeights[i]; exact for polynomials of
/// degree 15.
constexpr double kNodes[4] = {0.18343464249564980, 0.52553240991632899, 0.79666647741362674, 0.96028985649753623};
constexpr double kWeights[4] = {0.36268378337836198, 0.31370664587788729, 0.22238103445337447, 0.10122853629037626};

/// Quadrature stops refining an interval once its two halves agree with it to this much per unit of y, or once the
/// transmittance at its start is this small (the transmittance falls along y, so the interval's integral is then
/// below it times its width). The estimate |halves - whole| bounds the error of the whole rule, and the halves are
/// far more accurate than that, so the sum errs by well under 1e-14 in all.
constexpr double kTolerance = 1e-14;
/// Bisections at most: 2^-50 of a piece is below the resolution of y near 1.
constexpr int kMaxDepth = 50;

/// T(y) = exp(-tau(y)) across a piece whose alpha runs linearly from a0 to a1 over `ratio` reference lengths.
class PieceTransmittance {
 public:
  PieceTransmittance(double a0, double a1, double ratio) : mA0(a0), mA1(a1), mRatio(ratio) {}

  double operator()(double y) const {
    if (y <= 0) return 1;  // also where a0 = 1, whose extinction is infinite but integrable
    const double a = mA0 * (1 - y) + mA1 * y;
    return std::exp(-mRatio * y * meanExtinction(mA0, a));
  }

  /// The 8-point rule on [y0, y1].
  double gauss(double y0, double y1) const {
    const double middle = 0.5 * (y0 + y1), half = 0.5 * (y1 - y0);
    double sum = 0;
    for (int i = 0; i < 4; ++i)
      sum += kWeights[i] * ((*this)(middle - half * kNodes[i]) + (*this)(middle + half * kNodes[i]));
    return half * sum;
  }

  /// Int_y0^y1 T, given the rule's value `whole` on it.
  double adaptive(double y0, double y1, double whole, int depth) const {
    const double middle = 0.5 * (y0 + y1);
    const double left = gauss(y0, middle), right = gauss(middle, y1);
    const double halves = left + right;
    if (depth >= kMaxDepth || std::abs(halves - whole) <= kTolerance * (y1 - y0) || (*this)(y0) <= kTolerance)
      return halves;
    return adaptive(y0, middle, left, depth + 1) + adaptive(middle, y1, right, depth + 1);
  }

 private:
  double mA0, mA1, mRatio;
};

/// A piece of `ratio` reference lengths, colour and alpha running linearly from `entry` to `exit`.
RaySpan crossPiece(const glm::dvec4& entry, const glm::dvec4& exit, double ratio) {
  const double a0 = std::clamp(entry.a, 0.0, 1.0), a1 = std::clamp(exit.a, 0.0, 1.0);
  const double mean = meanExtinction(a0, a1);
  if (!(mean > 0)) return {};  // alpha 0 throughout
  const double tau = ratio * mean;
  if (tau == kInfinity) return {glm::dvec3(entry), 0.0};
  const double absorbed = -std::expm1(-tau);
  const glm::dvec3 c0(entry), c1(exit);
  if (c0 == c1) return {c0 * absorbed, 1 - absorbed};
  const double t = 1 - absorbed;
  return crossLinearPiece(c0, c1, t, std::clamp(meanTransmittance(a0, a1, ratio), t, 1.0));
}

}  // namespace

// With b = 1 - a linear, the mean is ((b0 ln b0 - b1 ln b1) / (b1 - b0)) + 1; that cancels badly when b0 and b1
// are close, where the series in x = (b1 - b0) / (b0 + b1) around the midpoint takes over:
// -ln m + x^2/6 + x^4/20 + x^6/42 + x^8/72 + x^10/110 (the next term is below 1e-13 of it for |x| < 0.1).
double meanExtinction(double a0, double a1) {
  if (a0 >= 1 && a1 >= 1) return kInfinity;
  const double b0 = 1 - a0, b1 = 1 - a1;
  const double x = (b1 - b0) / (b0 + b1);
  if (std::abs(x) < 0.1) {
    const double x2 = x * x;
    const double series = x2 * (1.0 / 6 + x2 * (1.0 / 20 + x2 * (1.0 / 42 + x2 * (1.0 / 72 + x2 / 110))));
    return -std::log1p(-0.5 * (a0 + a1)) + series;
  }
  // ln b from log1p(-a): exact for small a, and b ln b -> 0 as b -> 0 (an alpha of 1 at one end is integrable).
  auto bLogB = [](double a, double b) { return b > 0 ? b * std::log1p(-a) : 0.0; };
  return (bLogB(a0, b0) - bLogB(a1, b1)) / (b1 - b0) + 1;
}

glm::dvec4 linearAround(const std::vector<TransferFunction::Point>& points, double m, double s) {
  const auto right = std::upper_bound(points.begin(), points.end(), m,
                                      [](double v, const TransferFunction::Point& p) { return v < p.x; });
  if (right == points.begin()) return points.front().rgba;
  if (right == points.end()) return points.back().rgba;
  const TransferFunction::Point& a = *(right - 1);
  const TransferFunction::Point& b = *right;  // a.x <= m < b.x, so a.x < b.x
  const double t = std::clamp((s - a.x) / (b.x - a.x), 0.0, 1.0);
  return a.rgba + t * (b.rgba - a.rgba);
}

double meanTransmittance(double a0, double a1, double ratio) {
  if (!(ratio > 0)) return 1;
  if (a0 == a1) {
    // Constant extinction: m = (1 - e^-tau) / tau.
    const double tau = ratio * meanExtinction(a0, a1);
    if (tau == kInfinity) return 0;
    return tau > 0 ? -std::expm1(-tau) / tau : 1.0;
  }
  const PieceTransmittance transmittance(a0, a1, ratio);
  return transmittance.adaptive(0, 1, transmittance.gauss(0, 1), 0);
}

glm::dvec4 integrateSegment(const TransferFunction& tf, double sf, double sb, double ratio) {
  if (!(ratio > 0)) return glm::dvec4(0.0);
  ratio = std::min(ratio, 1e300);  // an infinite length is opaque wherever alpha > 0, as a huge one is
  if (std::isnan(sf)) sf = 0;
  if (std::isnan(sb)) sb = 0;
  if (sf == sb) {
    const glm::dvec4 c = tf.evaluate(sf);
    const double alpha = TransferFunction::correctOpacity(c.a, ratio);
    return {glm::dvec3(c) * alpha, alpha};
  }
  // Walk the control points in the order the value meets them, cutting the segment at each one strictly inside it
  // (a step's second point falls on the same cut and is passed over).
  const std::vector<TransferFunction::Point>& points = tf.points();
  const double span = sb - sf;
  RaySpan sum;
  double u0 = 0, s0 = sf;
  auto piece = [&](double u1, double s1) {
    const double middle = 0.5 * (s0 + s1);
    sum = over(sum, crossPiece(linearAround(points, middle, s0), linearAround(points, middle, s1), ratio * (u1 - u0)));
    u0 = u1, s0 = s1;
  };
  const size_t n = points.size();
  for (size_t i = 0; i < n && sum.transmittance > 0; ++i) {
    const double x = points[span > 0 ? i : n - 1 - i].x;
    const double u = (x - sf) / span;
    if (u > u0 && u < 1) piece(u, x);
  }
  if (sum.transmittance > 0) piece(1, sb);
  return {sum.color, 1 - sum.transmittance};
}

}  // namespace voxbrick::render
