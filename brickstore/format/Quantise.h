// Quantising prep's input to u8 or u16: a value range mapped linearly onto the integers of the type.
#pragma once

#include <cstdint>
#include <string>

#include "brickstore/format/Types.h"

namespace voxbrick::store {

/// Values [lo, hi] mapped linearly onto the integers [0, steps] of a store type (u8: 255 steps, u16: 65535):
/// q = round((v - lo) · steps / (hi - lo)), clamped to [0, steps]. For v in [lo, hi],
/// |dequantise(quantise(v)) - v| <= (hi - lo) / (2 · steps) (plus round-off of the doubles).
struct Quantisation {
  ValueType type = ValueType::U8;  ///< U8 or U16
  double lo = 0, hi = 1;           ///< the values stored as 0 and as `steps()`

  /// 255 for U8, 65535 for U16.
  double steps() const { return type == ValueType::U16 ? 65535.0 : 255.0; }
  /// v in steps: (v - lo) · steps / (hi - lo), neither rounded nor clamped (for value windows).
  double toSteps(double v) const { return (v - lo) * (steps() / (hi - lo)); }
  /// The stored integer of v (round half up, clamped to [0, steps]).
  double quantise(double v) const;
  /// The value a stored q stands for: lo + q · (hi - lo) / steps.
  double dequantise(double q) const { return lo + q * ((hi - lo) / steps()); }
  /// Throws InputError unless the type is U8 or U16 and lo < hi are both finite.
  void validate() const;
  bool operator==(const Quantisation&) const = default;
};

/// "u8" or "u16" as a quantisation type; throws InputError naming the text otherwise.
ValueType parseQuantiseType(const std::string& text);

/// "lo,hi" as two finite numbers with lo < hi; throws InputError naming the text otherwise.
void parseQuantiseRange(const std::string& text, Quantisation& q);

}  // namespace voxbrick::store
