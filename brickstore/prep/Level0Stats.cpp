// Level-0 statistics: a parallel reduction per batch of slices, and the scan that runs them over a whole source.
#include "brickstore/prep/Level0Stats.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

template <typename T>
struct Partial {
  T lo = std::numeric_limits<T>::max(), hi = std::numeric_limits<T>::lowest();
  int64_t active = 0, nonFinite = 0;
  int64_t firstBad = -1;  // index of the first non-finite value under the error policy
};

/// Rows of floats with no NaN or Inf: range and active count in eight lanes that the compiler vectorises, the same
/// result as the scalar loop (which keeps the first of equal extremes: the sign of the first zero when 0 is one).
/// Returns false, changing nothing, if a value is not finite.
bool observeFinite(const float* v, int64_t count, float bg, Partial<float>& p) {
  if (count <= 0) return true;
  constexpr int kLanes = 8;
  float lo[kLanes], hi[kLanes];
  int64_t active[kLanes] = {};
  uint32_t bad[kLanes] = {};
  for (int k = 0; k < kLanes; ++k) lo[k] = hi[k] = v[0];
  int64_t n = 0;
  for (; n + kLanes <= count; n += kLanes)
    for (int k = 0; k < kLanes; ++k) {
      const float x = v[n + k];
      uint32_t bits;
      std::memcpy(&bits, &x, sizeof bits);
      bad[k] |= uint32_t((bits & 0x7f800000u) == 0x7f800000u);
      lo[k] = x < lo[k] ? x : lo[k];
      hi[k] = hi[k] < x ? x : hi[k];
      active[k] += x != bg;
    }
  for (; n < count; ++n) {
    const float x = v[n];
    bad[0] |= uint32_t(!std::isfinite(x));
    lo[0] = x < lo[0] ? x : lo[0];
    hi[0] = hi[0] < x ? x : hi[0];
    active[0] += x != bg;
  }
  Partial<float> q = p;
  for (int k = 0; k < kLanes; ++k) {
    if (bad[k]) return false;
    q.lo = std::min(q.lo, lo[k]);
    q.hi = std::max(q.hi, hi[k]);
    q.active += active[k];
  }
  if (q.lo == 0.0f || q.hi == 0.0f) {
    const float* zero = std::find(v, v + count, 0.0f);  // the scalar loop keeps the first zero it meets
    if (q.lo == 0.0f && !(p.lo <= 0.0f)) q.lo = *zero;
    if (q.hi == 0.0f && !(p.hi >= 0.0f)) q.hi = *zero;
  }
  p = q;
  return true;
}

}  // namespace

void Level0Stats::observe(int64_t z0, int64_t count, void* values) {
  dispatchType(mInfo.type, [&](auto tag) { observeTyped(z0, count, static_cast<decltype(tag)*>(values)); });
}

template <typename T>
void Level0Stats::observeTyped(int64_t z0, int64_t count, T* v) {
  const int64_t sliceValues = mInfo.dims.x * mInfo.dims.y, rowValues = mInfo.dims.x;
  const T bg = static_cast<T>(mBackground);
  const bool refuse = mPolicy == NonFinitePolicy::Error;
  const Partial<T> total = tbb::parallel_reduce(
      tbb::blocked_range<int64_t>(0, count * mInfo.dims.y), Partial<T>{},
      [&](const tbb::blocked_range<int64_t>& rows, Partial<T> p) {
        if constexpr (std::is_same_v<T, float>)
          if (observeFinite(v + rows.begin() * rowValues, (rows.end() - rows.begin()) * rowValues, bg, p)) return p;
        for (int64_t n = rows.begin() * rowValues; n != rows.end() * rowValues; ++n) {
          if constexpr (std::is_floating_point_v<T>) {
            if (!std::isfinite(v[n])) {
              if (refuse) {
                if (p.firstBad < 0) p.firstBad = n;
                continue;
              }
              v[n] = bg;
              ++p.nonFinite;
            }
          }
          p.lo = std::min(p.lo, v[n]);
          p.hi = std::max(p.hi, v[n]);
          p.active += v[n] != bg;
        }
        return p;
      },
      [](Partial<T> a, const Partial<T>& b) {
        a.lo = std::min(a.lo, b.lo);
        a.hi = std::max(a.hi, b.hi);
        a.active += b.active;
        a.nonFinite += b.nonFinite;
        if (a.firstBad < 0) a.firstBad = b.firstBad;
        return a;
      });
  if (total.firstBad >= 0) {
    const int64_t n = total.firstBad;
    const int64_t z = z0 + n / sliceValues, y = (n % sliceValues) / mInfo.dims.x, x = n % mInfo.dims.x;
    throw InputError(mInfo.description + ": non-finite value at voxel (" + std::to_string(x) + ", " +
                     std::to_string(y) + ", " + std::to_string(z) + ") (policy: error)");
  }
  min = std::min(min, double(total.lo));
  max = std::max(max, double(total.hi));
  active += total.active;
  nonFinite += total.nonFinite;
}

Level0Stats scanLevel0(VolumeSource& source, double background, NonFinitePolicy policy,
                       const std::function<void(int64_t, int64_t)>& progress, int64_t batchBytes) {
  const VolumeInfo& info = source.info();
  const int64_t sliceBytes = info.dims.x * info.dims.y * static_cast<int64_t>(valueSize(info.type));
  const int64_t batch = std::clamp<int64_t>(batchBytes / std::max<int64_t>(1, sliceBytes), 1, info.dims.z);
  std::vector<char> buffer(static_cast<size_t>(batch * sliceBytes));
  Level0Stats stats(info, background, policy);
  for (int64_t z = 0; z < info.dims.z;) {
    const int64_t count = std::min(batch, info.dims.z - z);
    source.readSlices(count, buffer.data());
    stats.observe(z, count, buffer.data());
    z += count;
    if (progress) progress(z, info.dims.z);
  }
  return stats;
}

}  // namespace voxbrick::store
