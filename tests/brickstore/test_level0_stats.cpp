// Level-0 statistics of float slices against a plain loop in z order: the vectorised pass for finite rows must give
// the same range (the sign of a zero extreme included), active count and non-finite handling.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "brickstore/format/Errors.h"
#include "brickstore/prep/Level0Stats.h"

namespace voxbrick::store {
namespace {

struct Expected {
  float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
  int64_t active = 0, nonFinite = 0;
};

/// The statistics as one scalar pass in z order computes them (non-finite values replaced by the background).
Expected reference(std::vector<float> v, float bg) {
  Expected e;
  for (float& x : v) {
    if (!std::isfinite(x)) {
      x = bg;
      ++e.nonFinite;
    }
    e.lo = std::min(e.lo, x);
    e.hi = std::max(e.hi, x);
    e.active += x != bg;
  }
  return e;
}

bool sameBits(double a, float b) {
  const float f = static_cast<float>(a);
  return std::memcmp(&f, &b, sizeof f) == 0;
}

/// Observes `v` (dims.x x dims.y x dims.z) in batches of `batch` slices and compares with the reference.
void expectStats(const std::vector<float>& v, const Vec3i& dims, float bg, int64_t batch) {
  VolumeInfo info;
  info.dims = dims;
  info.type = ValueType::F32;
  info.description = "test";
  Level0Stats stats(info, bg, NonFinitePolicy::Background);
  std::vector<float> copy = v;
  const int64_t slice = dims.x * dims.y;
  for (int64_t z = 0; z < dims.z; z += batch) stats.observe(z, std::min(batch, dims.z - z), copy.data() + z * slice);
  const Expected e = reference(v, bg);
  EXPECT_TRUE(sameBits(stats.min, e.lo)) << stats.min << " vs " << e.lo;
  EXPECT_TRUE(sameBits(stats.max, e.hi)) << stats.max << " vs " << e.hi;
  EXPECT_EQ(stats.active, e.active);
  EXPECT_EQ(stats.nonFinite, e.nonFinite);
  for (size_t n = 0; n < v.size(); ++n)
    if (!std::isfinite(v[n])) {
      ASSERT_EQ(copy[n], bg) << "non-finite voxel " << n << " not replaced";
    }
}

std::vector<float> noise(const Vec3i& dims, float lo, float hi, unsigned seed) {
  std::vector<float> v(static_cast<size_t>(dims.volume()));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(lo, hi);
  for (float& x : v) x = value(rng);
  return v;
}

TEST(Level0Stats, FloatRangeAndActiveCountAsAScalarPass) {
  const Vec3i dims{37, 29, 11};  // rows of 37 values: lanes of 8 end mid-row
  std::vector<float> v = noise(dims, -2.0f, 5.0f, 1);
  for (size_t n = 0; n < v.size(); n += 7) v[n] = 0.0f;  // background voxels
  expectStats(v, dims, 0.0f, 3);
  expectStats(v, dims, 1.5f, 11);
}

TEST(Level0Stats, ZeroExtremesKeepTheSignOfTheFirstZero) {
  const Vec3i dims{40, 30, 6};
  for (const float first : {0.0f, -0.0f}) {
    std::vector<float> up = noise(dims, 0.5f, 3.0f, 2);  // min is a zero: the first zero met, whatever its sign
    up[1234] = first;
    up[2345] = -first;
    up[6000] = first;
    expectStats(up, dims, 1.0f, 2);
    std::vector<float> down = noise(dims, -3.0f, -0.5f, 3);  // max is a zero
    down[999] = first;
    down[5000] = -first;
    expectStats(down, dims, -1.0f, 4);
  }
}

TEST(Level0Stats, NonFiniteValuesAreReplacedAndCounted) {
  const Vec3i dims{33, 17, 9};
  std::vector<float> v = noise(dims, -1.0f, 1.0f, 4);
  v[5] = std::numeric_limits<float>::quiet_NaN();
  v[700] = std::numeric_limits<float>::infinity();
  v[4000] = -std::numeric_limits<float>::infinity();
  expectStats(v, dims, 0.25f, 2);
}

TEST(Level0Stats, NonFiniteValueRefusedUnderTheErrorPolicy) {
  const Vec3i dims{16, 8, 4};
  std::vector<float> v = noise(dims, -1.0f, 1.0f, 5);
  v[16 * 8 * 2 + 16 * 3 + 5] = std::numeric_limits<float>::quiet_NaN();
  VolumeInfo info;
  info.dims = dims;
  info.type = ValueType::F32;
  info.description = "test";
  Level0Stats stats(info, 0.0, NonFinitePolicy::Error);
  try {
    stats.observe(0, dims.z, v.data());
    FAIL() << "a NaN was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("(5, 3, 2)"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace voxbrick::store
