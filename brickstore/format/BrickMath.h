// The arithmetic that decides a store's values, shared by prep and by the stores read live so that both give the same
// bytes: the voxels a brick reads, its record range and emptiness, and the pyramid's 2x2x2 average.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <type_traits>

#include "brickstore/format/Types.h"

namespace voxbrick::store {

/// A brick's sample range (border included).
struct MinMaxPair {
  float min = 0, max = 0;
};

/// sampleRange of floats in eight lanes the compiler vectorises (the scalar loop's chain of dependent min and max
/// took three quarters of cutting a brick): the same result, the sign of a zero extreme being that of the first
/// zero, as the scalar loop keeps the first of equal values. False, with nothing set, if a sample is NaN.
inline bool sampleRangeLanes(const float* samples, size_t count, float background, MinMaxPair& range,
                             bool& allBackground) {
  constexpr size_t kLanes = 8;
  float lo[kLanes], hi[kLanes];
  bool nan[kLanes] = {}, other[kLanes] = {};
  for (size_t k = 0; k < kLanes; ++k) lo[k] = hi[k] = samples[0];
  size_t n = 0;
  for (; n + kLanes <= count; n += kLanes)
    for (size_t k = 0; k < kLanes; ++k) {
      const float x = samples[n + k];
      lo[k] = x < lo[k] ? x : lo[k];
      hi[k] = hi[k] < x ? x : hi[k];
      nan[k] |= x != x;
      other[k] |= x != background;
    }
  for (; n < count; ++n) {
    const float x = samples[n];
    lo[0] = x < lo[0] ? x : lo[0];
    hi[0] = hi[0] < x ? x : hi[0];
    nan[0] |= x != x;
    other[0] |= x != background;
  }
  range = {lo[0], hi[0]};
  bool anyOther = false;
  for (size_t k = 0; k < kLanes; ++k) {
    if (nan[k]) return false;
    range.min = std::min(range.min, lo[k]);
    range.max = std::max(range.max, hi[k]);
    anyOther |= other[k];
  }
  if (range.min == 0.0f || range.max == 0.0f) {
    const float zero = *std::find(samples, samples + count, 0.0f);
    if (range.min == 0.0f) range.min = zero;
    if (range.max == 0.0f) range.max = zero;
  }
  allBackground = !anyOther;
  return true;
}

/// The [min, max] of a brick's samples (border included) and whether every one equals the background: what its
/// record holds, and whether it is stored.
template <typename T>
MinMaxPair sampleRange(const T* samples, size_t count, T background, bool& allBackground) {
  if constexpr (std::is_same_v<T, float>) {
    MinMaxPair range;
    if (count > 0 && sampleRangeLanes(samples, count, background, range, allBackground)) return range;
  }
  T lo = samples[0], hi = samples[0];
  bool empty = true;
  for (size_t n = 0; n < count; ++n) {
    lo = std::min(lo, samples[n]);
    hi = std::max(hi, samples[n]);
    empty = empty && samples[n] == background;
  }
  allBackground = empty;
  return {static_cast<float>(lo), static_cast<float>(hi)};
}

/// The voxels brick `idx` of a level of `dims` reads: [i*B - 1, i*B + B] along each axis, clamped to the level.
inline void brickVoxels(const Vec3i& idx, int64_t B, const Vec3i& dims, Vec3i& lo, Vec3i& hi) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::max<int64_t>(idx[a] * B - 1, 0);
    hi[a] = std::min<int64_t>(idx[a] * B + B, dims[a] - 1);
  }
}

/// The downsampled value of eight finer values, exactly as the pyramid computes it: their mean, integer types rounded
/// half up.
template <typename T>
T downsampleAverage(double sum) {
  if constexpr (std::is_floating_point_v<T>)
    return static_cast<T>(sum / 8.0);
  else
    return static_cast<T>(std::floor(sum / 8.0 + 0.5));
}

/// Coarse voxel from the finer voxels (x0 | x1, y0 | y1) of two finer z-planes p0 and p1 whose rows hold `stride`
/// values (x1 = x0 + 1, or x0 where the finer level ends; likewise y1 and p1): the pyramid's one arithmetic, in its
/// one summation order, shared by prep (DownsampleSource) and by stores that build coarse levels on demand.
template <typename T>
T downsampleVoxel(const T* p0, const T* p1, int64_t stride, int64_t x0, int64_t x1, int64_t y0, int64_t y1) {
  double sum = 0;
  for (const T* plane : {p0, p1})
    sum += double(plane[x0 + stride * y0]) + double(plane[x1 + stride * y0]) + double(plane[x0 + stride * y1]) +
           double(plane[x1 + stride * y1]);
  return downsampleAverage<T>(sum);
}

}  // namespace voxbrick::store
