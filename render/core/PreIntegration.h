// Pre-integrated classification (Engel, Kraus & Ertl 2001) without GL: the table of segment colours and opacities.
//
// The model is ARCHITECTURE.md's optical model in its continuous limit (what ReferenceRenderer converges to). Along
// a ray the normalised value s runs LINEARLY from sf (front sample) to sb (back sample) over a segment of world
// length d = r * L (L the transfer function's reference length). With the transfer function's straight colour
// rgb(s) and alpha a(s) per reference length, the extinction per reference length is k(s) = -ln(1 - a(s)) (infinite
// where a = 1) and
//   A = 1 - exp(-r * Int_0^1 k(s(u)) du)
//   C = r * Int_0^1 rgb(s(u)) k(s(u)) exp(-r * Int_0^u k(s(v)) dv) du        (premultiplied, front to back)
// with s(u) = sf + u (sb - sf). For sf == sb that is post-classification's 1 - (1 - a)^r and C = rgb * A.
#pragma once

#include <vector>

#include <glm/glm.hpp>

#include "render/core/TransferFunction.h"

namespace voxbrick::render {

/// The shape of a pre-integration table and the texel mapping the GPU uses to read it.
///
/// Layout: `resolution`^2 * `layers` RGBA32F texels (premultiplied colour, opacity), x = front value fastest, then
/// y = back value, then z = length layer: texel (x, y, z) is element x + R * (y + R * z), ready for a 3D texture (or
/// a 2D array) with x, y, z as its s, t, r axes. Texel (x, y, z) holds the segment from sf = x / (R - 1) to
/// sb = y / (R - 1) of ratio layerRatio(z).
///
/// Mapping (linear filtering, clamp to edge): value s lies at texture coordinate (s * (R - 1) + 0.5) / R, so 0 and 1
/// are the centres of the first and last texels and sf == sb lies on the diagonal. Layers are spaced geometrically
/// from ratioMin to ratioMax (log-uniform in r, which spreads the error of interpolating between layers evenly:
/// it grows with (delta r / r)^2); ratio r lies at layer coordinate
///   z = (clamp(ln(r / ratioMin) * layerScale(), 0, layers - 1) + 0.5) / layers.
/// The GLSL mirror of coordinates():
///   vec3 c = vec3((vec2(sf, sb) * (R - 1.0) + 0.5) / R,
///                 (clamp(log(r / ratioMin) * layerScale, 0.0, layers - 1.0) + 0.5) / layers);
struct PreIntegrationSpec {
  /// Samples per value axis, R in [2, 1024]: the same for the front and the back axis.
  int resolution = 256;
  /// Length layers in [1, 64]; 1 requires ratioMin == ratioMax (an orthographic frame).
  int layers = 1;
  /// The shortest and longest segment the frame draws, in reference lengths (step / L_ref, step / (L_ref * cos) for
  /// the most oblique perspective ray); finite, 0 < ratioMin <= ratioMax.
  double ratioMin = 1;
  double ratioMax = 1;

  /// Throws RenderInputError naming the field and value if a field is outside the ranges above.
  void validate() const;
  /// The fewest layers (at most 64) for ratios in [ratioMin, ratioMax] such that the filter's linear interpolation
  /// between layers (in ln r) is off by at most `maxError` in opacity: A = 1 - exp(-x) with x = r * K has
  /// |d^2 A / d(ln r)^2| = |(1 - x) x e^-x| <= 0.31, so the interpolation error is at most 0.039 * (ln(ratioMax /
  /// ratioMin) / (layers - 1))^2; premultiplied colour behaves alike (measured on the presets). Thin segments have
  /// a relative error in optical depth of (spacing in ln r)^2 / 8, which along a ray changes a composited opacity by
  /// at most the same bound. 1 when ratioMin == ratioMax. Throws RenderInputError for ratios that validate()
  /// rejects or maxError outside (0, 1].
  static int layersFor(double ratioMin, double ratioMax, double maxError);
  /// The value sample x (or y) holds: x / (R - 1). Expects 0 <= x < R.
  double value(int x) const { return double(x) / double(resolution - 1); }
  /// The segment ratio of layer z: ratioMin * (ratioMax / ratioMin)^(z / (layers - 1)), exactly ratioMin for z = 0
  /// and ratioMax for z = layers - 1. Expects 0 <= z < layers.
  double layerRatio(int z) const;
  /// Layers per unit of ln(r): (layers - 1) / ln(ratioMax / ratioMin), 0 when ratioMax == ratioMin.
  double layerScale() const;
  /// Index of texel (x, y, z) in the table: x + R * (y + R * z).
  size_t index(int x, int y, int z) const {
    return size_t(x) + size_t(resolution) * (size_t(y) + size_t(resolution) * size_t(z));
  }
  /// Number of texels: R * R * layers.
  size_t texelCount() const { return index(0, 0, layers); }
  /// The texture coordinates of a lookup as the shader computes them (see the mapping above): sf and sb clamped to
  /// [0, 1], r to [ratioMin, ratioMax] (NaN reads as 0 for values and as ratioMin for r).
  glm::dvec3 coordinates(double sf, double sb, double r) const;
};

/// The pre-integration table of `tf` for `spec` (see PreIntegrationSpec for the layout), deterministic. Integrates
/// the transfer function exactly as TransferFunction::evaluate defines it (its control points, steps included), not
/// through the GPU's 1D table: the reference renderer converges to that function. The transmittance of every
/// segment is exact (closed-form optical depth of each linear piece); colour is exact where rgb is constant and
/// otherwise models the optical depth inside each piece of a 1/(R - 1) value cell as quadratic through its exact
/// values at the ends and the middle (error O(R^-4): below 3e-7 against a converged integration on the presets at
/// R = 256, ratios to 8). Opaque alphas (1) and any finite ratio give finite texels in [0, 1] with colour <= opacity.
/// Cost: O(R^2) exponentials per layer (one per value cell and diagonal of the table). Throws RenderInputError from
/// spec.validate().
std::vector<glm::vec4> buildPreIntegrationTable(const TransferFunction& tf, const PreIntegrationSpec& spec);

/// What the GPU reads for a segment (sf, sb, r): the table at spec.coordinates(sf, sb, r), trilinearly filtered
/// with clamp to edge, in double (GPUs round the filter weights, often to 8 bits). Throws RenderInputError if
/// `texels` does not hold spec.texelCount() elements.
glm::dvec4 samplePreIntegrationTable(const std::vector<glm::vec4>& texels, const PreIntegrationSpec& spec, double sf,
                                     double sb, double r);

}  // namespace voxbrick::render
