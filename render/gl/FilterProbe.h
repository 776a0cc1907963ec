// The texture unit's filter precision, measured on the context: GPUs interpolate a GL_LINEAR fetch with fixed-point
// weights (NVIDIA: 8 bits below the texel), llvmpipe in float. Two drawings that reach the same sample point by
// differently rounded coordinates (another atlas slot, slabs instead of slices, the ray caster) can then fetch values
// one weight step apart; the GL tests derive how far such drawings may differ from this (render/README.md).
#pragma once

#include <cmath>

#include "render/gl/GlContext.h"

namespace voxbrick::render {

/// The fractions between two texels the probe fetches at, one per column (the shader's PROBE_FRACTIONS).
inline constexpr int kFilterProbeFractions = 4096;

/// What filterPrecision measured.
struct FilterPrecision {
  /// The largest |fetched - exact| of a linear fetch between two texels 0 and 1 over kFilterProbeFractions evenly
  /// spread fractions: the weight's error (about 1e-7 where the filter is float, 1/512 or 1/256 with 8-bit weights).
  double maxWeightError = 0;
  /// The step between neighbouring weights the filter can give: the smallest difference between the distinct
  /// values fetched, or 0 where there are as many distinct values as fractions (no coarser than 1 /
  /// kFilterProbeFractions: float).
  double weightStep = 0;
  /// log2(1 / weightStep) rounded: the filter's sub-texel bits, 0 for a float filter.
  int subTexelBits() const { return weightStep > 0 ? int(std::lround(std::log2(1 / weightStep))) : 0; }
};

/// Draws a kFilterProbeFractions x 1 frame (shaders/filter_probe.frag.glsl) whose fragment i fetches a 2 x 1 x 1 3D
/// texture of `internalFormat` (texels 0 and 1, GL_LINEAR, as the atlas is) at the fraction
/// (i + 0.5) / kFilterProbeFractions between the texels, and reads it back. The format
/// matters: llvmpipe filters GL_R8 with 8-bit weights and GL_R32F in float; NVIDIA's are 8-bit for every format.
/// `context` must be current; the GL state the probe touches (program, vertex array, framebuffer, viewport, texture
/// unit 0) is left unbound. Throws RenderError on a GL failure.
FilterPrecision measureFilterPrecision(const GlContext& context, GLenum internalFormat = GL_R32F);

}  // namespace voxbrick::render
