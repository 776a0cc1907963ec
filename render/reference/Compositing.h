// Front-to-back emission–absorption compositing (ARCHITECTURE.md, optical model), generic in the accumulator's
// precision.
#pragma once

namespace voxbrick::render {

/// Accumulates premultiplied colour and opacity front to back: C ← C + (1 − A)·α'·c, A ← A + (1 − A)·α'.
/// `T` is the accumulator's number type (double for the reference; float and 16-bit types model GPU targets,
/// whose blender rounds every result to the target's precision).
template <typename T>
struct FrontToBack {
  T r{0}, g{0}, b{0}, a{0};

  /// Adds one sample of straight colour (cr, cg, cb) and corrected opacity alpha.
  void add(T cr, T cg, T cb, T alpha) {
    const T transmittance = T(1) - a;
    r = r + transmittance * (cr * alpha);
    g = g + transmittance * (cg * alpha);
    b = b + transmittance * (cb * alpha);
    a = a + transmittance * alpha;
  }
};

}  // namespace voxbrick::render
