// An in-memory VolumeSource for tests: a known array streamed as slices, optionally failing at a chosen slice.
#pragma once

#include <cstring>
#include <random>
#include <stdexcept>
#include <vector>

#include "brickstore/format/Errors.h"
#include "brickstore/source/VolumeSource.h"

namespace voxbrick::test {

template <typename T>
class ArraySource : public store::VolumeSource {
 public:
  ArraySource(store::Vec3i dims, store::ValueType type, std::vector<T> values, double background = 0)
      : mValues(std::move(values)) {
    mInfo.dims = dims;
    mInfo.spacing = {1, 1, 1};
    mInfo.type = type;
    mInfo.background = background;
    mInfo.description = "test array";
  }

  const store::VolumeInfo& info() const override { return mInfo; }
  void readSlices(int64_t count, void* dst) override {
    if (mNextZ + count > mInfo.dims.z) throw store::InputError("test array: read past the end");
    if (mFailAtZ >= 0 && mNextZ + count > mFailAtZ) throw store::InputError("test array: injected failure");
    const size_t slice = static_cast<size_t>(mInfo.dims.x * mInfo.dims.y);
    std::memcpy(dst, mValues.data() + static_cast<size_t>(mNextZ) * slice, sizeof(T) * slice * size_t(count));
    mNextZ += count;
  }

  /// Sets the voxel size (default 1, 1, 1).
  void setSpacing(const store::Vec3d& spacing) { mInfo.spacing = spacing; }
  /// Makes readSlices throw once it would deliver slice z.
  void failAt(int64_t z) { mFailAtZ = z; }
  T at(int64_t x, int64_t y, int64_t z) const { return mValues[size_t(x + mInfo.dims.x * (y + mInfo.dims.y * z))]; }
  const std::vector<T>& values() const { return mValues; }

 private:
  store::VolumeInfo mInfo;
  std::vector<T> mValues;
  int64_t mNextZ = 0;
  int64_t mFailAtZ = -1;
};

/// Random values in [lo, hi] with a seeded generator; a fraction `zeroFraction` of axis-aligned boxes set to 0.
template <typename T>
std::vector<T> randomVolume(store::Vec3i dims, double lo, double hi, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> dist(lo, hi);
  std::vector<T> v(static_cast<size_t>(dims.volume()));
  for (T& x : v) x = static_cast<T>(dist(rng));
  return v;
}

}  // namespace voxbrick::test
