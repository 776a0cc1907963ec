// The reference renderer's integration of one ray: the composite midpoint rule, refined where the transfer function
// bends, with the GPU's shading and empty-space jumps.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include <glm/glm.hpp>

#include "render/core/TransferFunction.h"
#include "render/reference/Compositing.h"
#include "render/reference/Headlight.h"
#include "render/reference/ReferenceFrame.h"
#include "render/reference/ReferenceRay.h"

namespace voxbrick::render::reference {

/// Below this transmittance a ray stops (see ReferenceRenderer's comment).
constexpr double kTerminateTransmittance = 1e-9;

/// The GPU's shading of colour `c` at ray parameter t: central differences half a voxel each way, two-sided Phong
/// headlight.
template <typename Sampler>
glm::dvec3 shade(const Frame& f, const Sampler& sample, const Ray& ray, double t, const glm::dvec3& c) {
  const glm::dvec3 world = ray.origin + t * ray.dir;
  const glm::dvec3 p = world / f.spacing + f.halfDims;
  glm::dvec3 gradient;
  for (int a = 0; a < 3; ++a) {
    glm::dvec3 d(0.0);
    d[a] = 0.5;
    gradient[a] = (sample(p + d) - sample(p - d)) / f.spacing[a];
  }
  const double magnitude = glm::length(gradient);
  if (!(magnitude > 1e-12)) return c;
  const glm::dvec3 normal = -gradient / magnitude;
  const glm::dvec3 toEye = f.basis.orthographic ? -f.basis.forward : glm::normalize(f.basis.eye - world);
  const glm::dvec2 light = headlight(std::abs(glm::dot(normal, toEye)));
  return c * light.x + glm::dvec3(light.y);
}

/// Integrates one ray: its output pixel (Scene::output: over the background, or with alpha), with its samples and
/// skipped bricks added to the counters.
///
/// Samples sit at the midpoints t_k of n equal segments of length h, and each sample's segment is composited as two
/// halves (which equals the midpoint rule). Between two consecutive samples whose normalised values straddle a
/// control point of the transfer function, or whose alphas differ by more than 1/16, the two halves are replaced by
/// a finer rule: the interval is cut where the value crosses each control point (bisection), and each piece gets
/// midpoint samples, more where alpha changes more. On every piece the transfer function is then linear in the
/// value and the extinction well resolved, so steps, spikes and kinks converge like smooth parts instead of O(h).
template <typename Sampler>
class RayIntegrator {
 public:
  RayIntegrator(const Frame& frame, const Sampler& sample, const Ray& ray, int64_t& samples, int64_t& skipped)
      : mFrame(frame), mScene(*frame.scene), mSample(sample), mRay(ray), mSamples(samples), mSkipped(skipped) {}

  glm::dvec4 run();

 private:
  struct Piece {
    glm::dvec3 color{0.0};
    double alpha = 0;    // corrected for the piece's length
    double tfAlpha = 0;  // the transfer function's, per reference length
  };

  double at(int64_t k) const { return mRay.t0 + (double(k) + 0.5) * mSegment; }
  glm::dvec3 voxel(double t) const { return (mRay.origin + t * mRay.dir) / mFrame.spacing + mFrame.halfDims; }
  double valueAt(double t) {
    ++mSamples;
    return std::clamp((mSample(voxel(t)) - mFrame.lo) * mFrame.inverseWidth, 0.0, 1.0);
  }
  Piece classify(double t, double s, double pieceLength) const {
    const glm::dvec4 c = mScene.transferFunction.evaluate(s);
    Piece piece{glm::dvec3(c), TransferFunction::correctOpacity(c.a, pieceLength / mFrame.referenceLength), c.a};
    if (piece.alpha > 0 && mScene.shading) piece.color = shade(mFrame, mSample, mRay, t, piece.color);
    return piece;
  }
  void add(const Piece& p) {
    if (p.alpha > 0) mAcc.add(p.color.r, p.color.g, p.color.b, p.alpha);
  }
  bool opaque() const { return 1 - mAcc.a < kTerminateTransmittance; }
  void refine(double ta, double sa, double tb, double sb);
  void integratePiece(double a, double b, double& sLeft, double sRight);
  bool refined(double sa, const Piece& a, double sb, const Piece& b) const;
  std::optional<double> transparentUntil(double t) const;

  const Frame& mFrame;
  const Scene& mScene;
  const Sampler& mSample;
  const Ray& mRay;
  int64_t& mSamples;
  int64_t& mSkipped;
  FrontToBack<double> mAcc;
  double mSegment = 0;  // h, the length of one segment
};

template <typename Sampler>
glm::dvec4 RayIntegrator<Sampler>::run() {
  const double length = mRay.t1 - mRay.t0;
  if (length > 0) {
    const double segments = std::ceil(length / mFrame.step);
    const int64_t n = int64_t(segments);
    mSegment = length / segments;
    double tPrev = at(0), sPrev = valueAt(tPrev);
    Piece halfPrev = classify(tPrev, sPrev, 0.5 * mSegment);
    add(halfPrev);
    for (int64_t k = 1; k < n && !opaque(); ++k) {
      const double t = at(k), s = valueAt(t);
      const Piece half = classify(t, s, 0.5 * mSegment);
      if (refined(sPrev, halfPrev, s, half)) {
        refine(tPrev, sPrev, t, s);
      } else {
        add(halfPrev);
        add(half);
      }
      tPrev = t, sPrev = s, halfPrev = half;
      // Every sample before the ray leaves a transparent brick's box reads only that brick (border included), so
      // the intervals between them add exactly nothing: continue from the last sample inside.
      if (const std::optional<double> exit = transparentUntil(t)) {
        const double past = std::ceil((*exit - mRay.t0) / mSegment - 0.5);  // first midpoint past the exit
        const int64_t inside = std::clamp<int64_t>(int64_t(std::min(past, segments)) - 1, k, n - 1);
        if (inside > k) {
          tPrev = at(inside), sPrev = valueAt(tPrev), halfPrev = classify(tPrev, sPrev, 0.5 * mSegment);
          k = inside;
          mSkipped += 1;
        }
      }
    }
    if (!opaque()) add(halfPrev);
  }
  return mScene.output(glm::dvec3(mAcc.r, mAcc.g, mAcc.b), mAcc.a);
}

// Integrates the interval [ta, tb] between two mSamples finely: cut where the value crosses each control point
// between sa and sb, then several mSamples per piece.
template <typename Sampler>
void RayIntegrator<Sampler>::refine(double ta, double sa, double tb, double sb) {
  const bool rising = sa < sb;
  const auto first = std::upper_bound(mFrame.kinks.begin(), mFrame.kinks.end(), std::min(sa, sb));
  const auto last = std::upper_bound(mFrame.kinks.begin(), mFrame.kinks.end(), std::max(sa, sb));
  double left = ta;
  double sLeft = sa;
  for (ptrdiff_t i = 0; i < last - first; ++i) {
    const double x = rising ? first[i] : last[-1 - i];
    // Bisection keeps lo on the side of the value at `left`; 16 halvings place the cut within h / 65536.
    double lo = left, hi = tb;
    const bool above = (left == ta ? sa : valueAt(left)) >= x;
    if ((sb >= x) == above) continue;  // not monotone here: no crossing to cut at
    for (int iteration = 0; iteration < 16; ++iteration) {
      const double mid = 0.5 * (lo + hi);
      if ((valueAt(mid) >= x) == above)
        lo = mid;
      else
        hi = mid;
    }
    const double cut = 0.5 * (lo + hi);
    integratePiece(left, cut, sLeft, x);
    left = cut;
  }
  integratePiece(left, tb, sLeft, sb);
}

// Extinction −ln(1 − α) is not linear where α is, so a piece gets more mSamples the more α changes on it. The
// piece's values run from sLeft to sRight; sLeft moves on to sRight.
template <typename Sampler>
void RayIntegrator<Sampler>::integratePiece(double a, double b, double& sLeft, double sRight) {
  const double change =
      std::abs(mScene.transferFunction.evaluate(sRight).a - mScene.transferFunction.evaluate(sLeft).a);
  const int m = 2 + int(32 * change);
  for (int j = 0; j < m; ++j) {
    const double t = a + (j + 0.5) / m * (b - a);
    add(classify(t, valueAt(t), (b - a) / m));
  }
  sLeft = sRight;
}

// Refined: an interval where the value crosses a control point, or where alpha changes by more than 1/16.
template <typename Sampler>
bool RayIntegrator<Sampler>::refined(double sa, const Piece& a, double sb, const Piece& b) const {
  return std::abs(a.tfAlpha - b.tfAlpha) > 1.0 / 16 ||
         std::upper_bound(mFrame.kinks.begin(), mFrame.kinks.end(), std::min(sa, sb)) !=
             std::upper_bound(mFrame.kinks.begin(), mFrame.kinks.end(), std::max(sa, sb));
}

// The brick of the sample at t, if rays may jump over it: the parameter where the ray leaves its box.
template <typename Sampler>
std::optional<double> RayIntegrator<Sampler>::transparentUntil(double t) const {
  if (mFrame.transparent.empty()) return std::nullopt;
  const glm::dvec3 p = voxel(t);
  glm::dvec3 lo, hi;
  int64_t index = 0, stride = 1;
  for (int a = 0; a < 3; ++a) {
    const int64_t b = std::clamp<int64_t>(int64_t(std::floor(p[a] / mFrame.brickSize)), 0, mFrame.brickGrid[a] - 1);
    index += b * stride;
    stride *= mFrame.brickGrid[a];
    lo[a] = (double(b) * mFrame.brickSize - mFrame.halfDims[a]) * mFrame.spacing[a];
    hi[a] = (std::min(double(b + 1) * mFrame.brickSize, mFrame.dims[a]) - mFrame.halfDims[a]) * mFrame.spacing[a];
  }
  if (!mFrame.transparent[size_t(index)]) return std::nullopt;
  double exit = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (mRay.dir[a] != 0) exit = std::min(exit, ((mRay.dir[a] > 0 ? hi[a] : lo[a]) - mRay.origin[a]) / mRay.dir[a]);
  return exit;
}

}  // namespace voxbrick::render::reference
