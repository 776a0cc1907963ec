// Quantising prep's input to u8 or u16: a value range mapped linearly onto the integers of the type.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "brickstore/Level0Stats.h"
#include "brickstore/VolumeSource.h"

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

/// Another source's values quantised: slices are read one at a time through a staging slice of the inner type,
/// the non-finite policy is applied to them (Level0Stats, with the inner background), then each value is
/// quantised in parallel. The background becomes quantise(background).
class QuantisingSource final : public VolumeSource {
 public:
  /// `q` must be valid.
  QuantisingSource(VolumeSource& inner, const Quantisation& q, double background, NonFinitePolicy policy);

  const VolumeInfo& info() const override { return mInfo; }
  void readSlices(int64_t count, void* dst) override;

  /// The inner values seen so far: range, non-finite count (replaced by the background).
  const Level0Stats& innerStats() const { return mStats; }
  /// Finite inner values outside [lo, hi] so far (stored as 0 or steps).
  int64_t clamped() const { return mClamped; }
  /// Bytes of the staging slice, for memory planning.
  int64_t stagingBytes() const { return static_cast<int64_t>(mStaging.size()); }

 private:
  VolumeSource& mInner;
  Quantisation mQ;
  VolumeInfo mInfo;
  Level0Stats mStats;
  std::vector<char> mStaging;
  int64_t mNextZ = 0;
  int64_t mClamped = 0;
};

}  // namespace voxbrick::store
