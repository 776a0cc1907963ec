// Prep's input quantised to u8 or u16 as it streams (the mapping: brickstore/format/Quantise.h).
#pragma once

#include <cstdint>
#include <vector>

#include "brickstore/format/Quantise.h"
#include "brickstore/prep/Level0Stats.h"
#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

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
