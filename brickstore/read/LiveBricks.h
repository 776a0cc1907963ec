// What the two live backings of a store (a .vdb read live, an OME-Zarr) share to cut bricks as prep would: a brick's
// (B+2)^3 samples with clamped borders from a block of voxels, a coarse level's voxels as the pyramid's 2x2x2 average
// of the finer level's bricks (BrickMath.h's downsampleVoxel, as prep's), so that both give prep's bytes; the
// statistics of the voxels a level-0 brick owns; and a coarse brick read without the host cache.
#pragma once

#include <algorithm>
#include <array>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "brickstore/format/BrickMath.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"

namespace voxbrick::store::live {

/// The decoded bricks a coarse brick read without a `finer` fetch may keep while it is built (readWithoutFetch).
inline constexpr size_t kFallbackCacheBytes = size_t{256} << 20;

/// The brick's (B+2)^3 samples from a block holding its voxels [lo, hi] (x fastest), borders clamped.
template <typename T>
void gatherSamples(const T* block, const Vec3i& lo, const Vec3i& hi, const Vec3i& idx, int64_t B, const Vec3i& dims,
                   T* dst) {
  const int64_t E = B + 2, sx = hi.x - lo.x + 1, sy = hi.y - lo.y + 1;
  std::array<int64_t, kMaxBrickSize + 2> ox{}, oy{}, oz{};
  for (int64_t a = 0; a < E; ++a) {
    ox[size_t(a)] = std::clamp<int64_t>(idx.x * B + a - 1, 0, dims.x - 1) - lo.x;
    oy[size_t(a)] = (std::clamp<int64_t>(idx.y * B + a - 1, 0, dims.y - 1) - lo.y) * sx;
    oz[size_t(a)] = (std::clamp<int64_t>(idx.z * B + a - 1, 0, dims.z - 1) - lo.z) * sx * sy;
  }
  for (int64_t c = 0; c < E; ++c)
    for (int64_t b = 0; b < E; ++b) {
      const T* row = block + oz[size_t(c)] + oy[size_t(b)];
      for (int64_t a = 0; a < E; ++a) *dst++ = row[ox[size_t(a)]];
    }
}

/// Coarse voxels [lo, hi] of a level from the finer level `nf` (the interiors of its bricks, got through `finer`):
/// the pyramid's 2x2x2 average (downsampleVoxel), into `block` (x fastest).
template <typename T>
void averageFromFiner(const BrickStore& store, uint32_t fineLevel, const Vec3i& lo, const Vec3i& hi, const Vec3i& nf,
                      const BrickSamplesFetch& finer, T* block) {
  const int64_t B = store.brickSize(), E = B + 2;
  Vec3i flo, fhi;
  for (int a = 0; a < 3; ++a) {
    flo[a] = 2 * lo[a];
    fhi[a] = std::min(2 * hi[a] + 1, nf[a] - 1);
  }
  const int64_t wx = fhi.x - flo.x + 1, wy = fhi.y - flo.y + 1, wz = fhi.z - flo.z + 1;
  std::vector<T> window(size_t(wx * wy * wz));
  const T background = T(store.meta().background);
  for (int64_t fk = flo.z / B; fk <= fhi.z / B; ++fk)
    for (int64_t fj = flo.y / B; fj <= fhi.y / B; ++fj)
      for (int64_t fi = flo.x / B; fi <= fhi.x / B; ++fi) {
        const BrickKey fineKey{fineLevel, uint32_t(fi), uint32_t(fj), uint32_t(fk)};
        const Vec3i blo{std::max(fi * B, flo.x), std::max(fj * B, flo.y), std::max(fk * B, flo.z)};
        const Vec3i bhi{std::min(fi * B + B - 1, fhi.x), std::min(fj * B + B - 1, fhi.y),
                        std::min(fk * B + B - 1, fhi.z)};
        const int64_t run = bhi.x - blo.x + 1;
        std::shared_ptr<const void> samples;
        if (store.isStored(fineKey)) samples = finer(fineKey);
        const T* s = static_cast<const T*>(samples.get());
        for (int64_t z = blo.z; z <= bhi.z; ++z)
          for (int64_t y = blo.y; y <= bhi.y; ++y) {
            T* out = window.data() + (blo.x - flo.x) + wx * ((y - flo.y) + wy * (z - flo.z));
            if (s)
              std::memcpy(out, s + (blo.x - fi * B + 1) + E * ((y - fj * B + 1) + E * (z - fk * B + 1)),
                          sizeof(T) * size_t(run));
            else
              std::fill_n(out, run, background);
          }
      }
  const int64_t sx = hi.x - lo.x + 1, sy = hi.y - lo.y + 1;
  for (int64_t z = lo.z; z <= hi.z; ++z) {
    const T* p0 = window.data() + (2 * z - flo.z) * wx * wy;
    const T* p1 = window.data() + (std::min(2 * z + 1, nf.z - 1) - flo.z) * wx * wy;
    for (int64_t y = lo.y; y <= hi.y; ++y) {
      const int64_t y0 = 2 * y - flo.y, y1 = std::min(2 * y + 1, nf.y - 1) - flo.y;
      T* out = block + sx * ((y - lo.y) + sy * (z - lo.z));
      for (int64_t x = lo.x; x <= hi.x; ++x)
        *out++ = downsampleVoxel(p0, p1, wx, 2 * x - flo.x, std::min(2 * x + 1, nf.x - 1) - flo.x, y0, y1);
    }
  }
}

/// The statistics of the voxels level-0 bricks own (no border), so that every voxel is counted once.
struct OwnedStats {
  double min = std::numeric_limits<double>::max(), max = std::numeric_limits<double>::lowest();
  int64_t active = 0;  ///< voxels other than the background

  /// Adds another brick's (or set of bricks') statistics.
  void merge(const OwnedStats& o) {
    min = std::min(min, o.min);
    max = std::max(max, o.max);
    active += o.active;
  }
};

/// The statistics of the voxels brick `idx` of level 0 (of `dims` voxels) owns, from its (B+2)^3 `samples`.
template <typename T>
OwnedStats ownedStats(const T* samples, const Vec3i& idx, int64_t B, const Vec3i& dims, double background) {
  const int64_t E = B + 2;
  const Vec3i own{std::min(B, dims.x - idx.x * B), std::min(B, dims.y - idx.y * B), std::min(B, dims.z - idx.z * B)};
  OwnedStats o;
  for (int64_t z = 1; z <= own.z; ++z)
    for (int64_t y = 1; y <= own.y; ++y)
      for (int64_t x = 1; x <= own.x; ++x) {
        const double v = double(samples[size_t(x + E * (y + E * z))]);
        o.min = std::min(o.min, v);
        o.max = std::max(o.max, v);
        o.active += v != background;
      }
  return o;
}

/// readStored for a caller that gave no `finer` fetch: `read` runs with a fetch through a temporary cache of
/// kFallbackCacheBytes over `store`. Correct, but it rebuilds the finer levels on every call.
inline void readWithoutFetch(const std::shared_ptr<const BrickStore>& store,
                             const std::function<void(const BrickSamplesFetch& finer)>& read) {
  BrickCache cache(store, kFallbackCacheBytes, 0);
  read([&cache](const BrickKey& k) {
    BrickHandle brick = cache.get(k);
    return std::shared_ptr<const void>(brick, brick->data());
  });
}

}  // namespace voxbrick::store::live
