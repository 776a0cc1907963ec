// Level-0 statistics: a parallel reduction per batch of slices, and the scan that runs them over a whole source.
#include "brickstore/Level0Stats.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>
#include <vector>

#include "brickstore/Errors.h"

namespace voxbrick::store {
namespace {

template <typename T>
struct Partial {
  T lo = std::numeric_limits<T>::max(), hi = std::numeric_limits<T>::lowest();
  int64_t active = 0, nonFinite = 0;
  int64_t firstBad = -1;  // index of the first non-finite value under the error policy
};

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
