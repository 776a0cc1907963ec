// Pre-integration tables: exact optical depth per linear piece of the transfer function, sliding-window compositing
// of value cells along each diagonal of the table.
#include "render/core/PreIntegration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "render/core/RenderErrors.h"
#include "render/core/SegmentIntegral.h"

namespace voxbrick::render {
namespace {

constexpr double kInfiniteDepth = std::numeric_limits<double>::infinity();

/// A part of a value cell on which the transfer function is linear. Depths are optical depths per reference length
/// of the segment's share of the whole cell (width of the piece in cells times mean extinction); the table scales
/// them by r / k.
struct Piece {
  double depth = 0;                   ///< of the whole piece
  double lowerDepth = 0;              ///< of its lower half (from its lower value to its middle value)
  glm::dvec3 lower{0.0}, upper{0.0};  ///< rgb at the piece's lower and upper value
};

/// The R - 1 cells [c / (R - 1), (c + 1) / (R - 1)] between the table's values, cut at the transfer function's
/// control points: cell c is pieces[first[c], first[c + 1]).
struct Cells {
  std::vector<Piece> pieces;
  std::vector<size_t> first;
};

Cells makeCells(const TransferFunction& tf, int cells) {
  const std::vector<TransferFunction::Point>& points = tf.points();
  Cells out;
  out.first.reserve(size_t(cells) + 1);
  std::vector<double> cuts;
  for (int c = 0; c < cells; ++c) {
    out.first.push_back(out.pieces.size());
    const double s0 = double(c) / cells, s1 = double(c + 1) / cells;
    cuts.assign(1, s0);
    for (const TransferFunction::Point& p : points)
      if (p.x > cuts.back() && p.x < s1) cuts.push_back(p.x);
    cuts.push_back(s1);
    for (size_t i = 0; i + 1 < cuts.size(); ++i) {
      const double a = cuts[i], b = cuts[i + 1];
      // Both ends from the formula of the linear part between them: at a step the piece takes its own side's value.
      const double m = 0.5 * (a + b);
      const glm::dvec4 va = linearAround(points, m, a), vb = linearAround(points, m, b);
      const double mean = meanExtinction(va.a, vb.a), lowerMean = meanExtinction(va.a, 0.5 * (va.a + vb.a));
      const double width = (b - a) * cells;
      out.pieces.push_back({mean > 0 ? width * mean : 0.0, lowerMean > 0 ? 0.5 * width * lowerMean : 0.0,
                            glm::dvec3(va), glm::dvec3(vb)});
    }
  }
  out.first.push_back(out.pieces.size());
  return out;
}

/// J(tau) = Int_0^1 (y^2 - y) exp(-tau y) dy = (2 - tau - (2 + tau) exp(-tau)) / tau^3, which cancels for small
/// tau: there its series -Sum_n (-tau)^n / (n! (n + 2) (n + 3)) (the first omitted term is below 3e-13 for tau < 0.1).
inline double quadraticMoment(double tau, double t) {
  if (tau < 0.1) {
    constexpr double kSeries[] = {-1.0 / 6, 1.0 / 12, -1.0 / 40, 1.0 / 180, -1.0 / 1008, 1.0 / 6720, -1.0 / 51840};
    double sum = 0;
    for (int n = 6; n >= 0; --n) sum = sum * tau + kSeries[n];
    return sum;
  }
  return (2 - tau - (2 + tau) * t) / (tau * tau * tau);
}

/// A linear piece crossed from colour `entry` to colour `exit`: optical depth `tau` in all, `half` over its first
/// half. Integrating C = Int rgb dP (P = 1 - T, the absorbed fraction) by parts, with rgb linear on the piece,
/// gives exactly
///   C = entry * (1 - m) + exit * (m - t),   t = exp(-tau), m = Int_0^1 T(y) dy (the mean transmittance).
/// T is exact at both ends and m is the only approximation: the optical depth from the entry is taken as the
/// quadratic tau y + c (y^2 - y) through the exact depth at the middle (c = 2 tau - 4 half, zero when extinction is
/// constant), to first order in c: m = (1 - t) / tau - c J(tau). The error is O(c^2), c itself O(tau / R).
inline RaySpan crossPiece(const glm::dvec3& entry, const glm::dvec3& exit, double tau, double half) {
  if (!(tau > 1e-300)) return {};
  if (tau == kInfiniteDepth) return {entry, 0.0};
  const double absorbed = -std::expm1(-tau);
  const double t = 1 - absorbed;
  const double mean = std::clamp(absorbed / tau - (2 * tau - 4 * half) * quadraticMoment(tau, t), t, 1.0);
  return crossLinearPiece(entry, exit, t, mean);
}

/// Piece p crossed upwards (ascending values) or downwards, with `scale` = r / k.
inline RaySpan crossPiece(const Piece& p, bool upwards, double scale) {
  const double tau = p.depth * scale, lower = p.lowerDepth * scale;
  return upwards ? crossPiece(p.lower, p.upper, tau, lower) : crossPiece(p.upper, p.lower, tau, tau - lower);
}

/// Cell c crossed upwards or downwards, with `scale` = r / k (the cell's share of the segment's reference lengths).
inline RaySpan crossCell(const Cells& cells, int c, bool upwards, double scale) {
  const size_t begin = cells.first[size_t(c)], end = cells.first[size_t(c) + 1];
  if (end - begin == 1) return crossPiece(cells.pieces[begin], upwards, scale);
  RaySpan span;
  for (size_t i = begin; i < end; ++i)
    span = over(span, crossPiece(cells.pieces[upwards ? i : end - 1 - (i - begin)], upwards, scale));
  return span;
}

glm::vec4 texel(const RaySpan& span) {
  return glm::vec4(glm::clamp(glm::vec3(span.color), 0.0f, 1.0f),
                   std::clamp(float(1 - span.transmittance), 0.0f, 1.0f));
}

/// Layer z's texels with k >= 1 cells between front and back. For a fixed k (one diagonal of the table, one
/// direction) every segment gives each cell the same share r / k of its length, so the cells' spans are computed
/// once per diagonal and each window of k consecutive cells is composited in O(1): windows are cut at multiples of
/// k, each is a suffix of one block of k cells followed by a prefix of the next (compositing is associative).
void fillDiagonals(const Cells& cells, const PreIntegrationSpec& spec, int z, std::vector<glm::vec4>& table) {
  const int n = spec.resolution - 1;
  const double r = spec.layerRatio(z);
  const size_t count = size_t(n);
  std::vector<RaySpan> cell(count), suffix(count), prefix(count);
  for (int k = 1; k <= n; ++k) {
    const double scale = r / k;
    for (int upwards = 0; upwards < 2; ++upwards) {
      // Traversal position m: cell m upwards, cell n - 1 - m downwards.
      for (int m = 0; m < n; ++m) cell[size_t(m)] = crossCell(cells, upwards ? m : n - 1 - m, upwards, scale);
      for (int block = 0; block < n; block += k) {
        const int end = std::min(block + k, n);
        suffix[size_t(end - 1)] = cell[size_t(end - 1)];
        for (int m = end - 2; m >= block; --m) suffix[size_t(m)] = over(cell[size_t(m)], suffix[size_t(m) + 1]);
        prefix[size_t(block)] = cell[size_t(block)];
        for (int m = block + 1; m < end; ++m) prefix[size_t(m)] = over(prefix[size_t(m) - 1], cell[size_t(m)]);
      }
      for (int m = 0; m + k <= n; ++m) {
        const RaySpan window = m % k == 0 ? suffix[size_t(m)] : over(suffix[size_t(m)], prefix[size_t(m + k - 1)]);
        const int front = upwards ? m : n - m;
        const int back = upwards ? m + k : n - m - k;
        table[spec.index(front, back, z)] = texel(window);
      }
    }
  }
}

}  // namespace

void PreIntegrationSpec::validate() const {
  const std::string what = "PreIntegrationSpec: ";
  if (resolution < 2 || resolution > 1024)
    throw RenderInputError(what + "resolution = " + std::to_string(resolution) + " is outside [2, 1024]");
  if (layers < 1 || layers > 64)
    throw RenderInputError(what + "layers = " + std::to_string(layers) + " is outside [1, 64]");
  if (!(ratioMin > 0) || !std::isfinite(ratioMin))
    throw RenderInputError(what + "ratioMin = " + numberText(ratioMin) + " is not finite and positive");
  if (!(ratioMax >= ratioMin) || !std::isfinite(ratioMax))
    throw RenderInputError(what + "ratioMax = " + numberText(ratioMax) +
                           " is not finite and at least ratioMin = " + numberText(ratioMin));
  if (layers == 1 && ratioMax != ratioMin)
    throw RenderInputError(what + "one layer holds one ratio, but ratioMin = " + numberText(ratioMin) +
                           " and ratioMax = " + numberText(ratioMax) + " differ");
}

int PreIntegrationSpec::layersFor(double ratioMin, double ratioMax, double maxError) {
  if (!(maxError > 0 && maxError <= 1))
    throw RenderInputError("PreIntegrationSpec::layersFor: maxError = " + numberText(maxError) + " is outside (0, 1]");
  PreIntegrationSpec{2, 2, ratioMin, ratioMax}.validate();
  if (ratioMax == ratioMin) return 1;
  // Linear interpolation of f over a spacing h errs by at most h^2 / 8 * max|f''|, and max|f''| < 0.31.
  const double spacing = std::sqrt(maxError / (0.31 / 8));
  return int(std::clamp(std::ceil(std::log(ratioMax / ratioMin) / spacing), 1.0, 63.0)) + 1;
}

double PreIntegrationSpec::layerRatio(int z) const {
  if (layers == 1 || z <= 0) return ratioMin;
  if (z >= layers - 1) return ratioMax;
  return ratioMin * std::pow(ratioMax / ratioMin, double(z) / double(layers - 1));
}

double PreIntegrationSpec::layerScale() const {
  return ratioMax > ratioMin ? double(layers - 1) / std::log(ratioMax / ratioMin) : 0.0;
}

glm::dvec3 PreIntegrationSpec::coordinates(double sf, double sb, double r) const {
  auto axis = [this](double s) {
    s = std::isnan(s) ? 0.0 : std::clamp(s, 0.0, 1.0);
    return (s * (resolution - 1) + 0.5) / resolution;
  };
  r = std::isnan(r) ? ratioMin : std::clamp(r, ratioMin, ratioMax);
  const double layer = std::clamp(std::log(r / ratioMin) * layerScale(), 0.0, double(layers - 1));
  return {axis(sf), axis(sb), (layer + 0.5) / layers};
}

std::vector<glm::vec4> buildPreIntegrationTable(const TransferFunction& tf, const PreIntegrationSpec& spec) {
  spec.validate();
  std::vector<glm::vec4> table(spec.texelCount());
  const Cells cells = makeCells(tf, spec.resolution - 1);
  for (int z = 0; z < spec.layers; ++z) {
    // The diagonal (sf == sb): post-classification's closed form, as TransferFunction::evaluate classifies.
    const double r = spec.layerRatio(z);
    for (int x = 0; x < spec.resolution; ++x) {
      const glm::dvec4 c = tf.evaluate(spec.value(x));
      const double alpha = TransferFunction::correctOpacity(c.a, r);
      table[spec.index(x, x, z)] = glm::vec4(glm::vec3(glm::dvec3(c) * alpha), float(alpha));
    }
    fillDiagonals(cells, spec, z, table);
  }
  return table;
}

glm::dvec4 samplePreIntegrationTable(const std::vector<glm::vec4>& texels, const PreIntegrationSpec& spec, double sf,
                                     double sb, double r) {
  if (texels.size() != spec.texelCount())
    throw RenderInputError("samplePreIntegrationTable: " + std::to_string(texels.size()) + " texels, the spec needs " +
                           std::to_string(spec.texelCount()));
  const glm::dvec3 coordinate = spec.coordinates(sf, sb, r);
  const int size[3] = {spec.resolution, spec.resolution, spec.layers};
  int lo[3], hi[3];
  double f[3];
  for (int a = 0; a < 3; ++a) {
    // GL's linear filter: texel space u * size - 0.5, the two texels around it, clamped to the edge.
    const double u = coordinate[a] * size[a] - 0.5;
    const double base = std::floor(u);
    f[a] = u - base;
    lo[a] = std::clamp(int(base), 0, size[a] - 1);
    hi[a] = std::clamp(int(base) + 1, 0, size[a] - 1);
  }
  glm::dvec4 sum(0.0);
  for (int corner = 0; corner < 8; ++corner) {
    double weight = 1;
    int at[3];
    for (int a = 0; a < 3; ++a) {
      const bool upper = (corner >> a) & 1;
      weight *= upper ? f[a] : 1 - f[a];
      at[a] = upper ? hi[a] : lo[a];
    }
    if (weight > 0) sum += weight * glm::dvec4(texels[spec.index(at[0], at[1], at[2])]);
  }
  return sum;
}

}  // namespace voxbrick::render
