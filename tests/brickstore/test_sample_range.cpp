// A brick's sample range (its record's min and max, and whether it is stored) from the vectorised float pass
// against the scalar loop it replaced: the same values, bit for bit, with zero extremes of either sign and NaN.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "brickstore/prep/SlabBricker.h"

namespace voxbrick::store {
namespace {

struct Scalar {
  float lo, hi;
  bool empty;
};

Scalar scalarRange(const std::vector<float>& v, float background) {
  Scalar s{v[0], v[0], true};
  for (const float x : v) {
    s.lo = std::min(s.lo, x);
    s.hi = std::max(s.hi, x);
    s.empty = s.empty && x == background;
  }
  return s;
}

bool sameFloatBits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void expectScalar(const std::vector<float>& v, float background) {
  bool empty = false;
  const MinMaxPair r = sampleRange(v.data(), v.size(), background, empty);
  const Scalar s = scalarRange(v, background);
  EXPECT_TRUE(sameFloatBits(r.min, s.lo)) << r.min << " vs " << s.lo;
  EXPECT_TRUE(sameFloatBits(r.max, s.hi)) << r.max << " vs " << s.hi;
  EXPECT_EQ(empty, s.empty);
}

TEST(SampleRange, FloatsAsTheScalarLoop) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> value(-4.0f, 9.0f);
  for (const size_t count : {size_t(1), size_t(7), size_t(8), size_t(13), size_t(34 * 34 * 34)}) {
    std::vector<float> v(count);
    for (float& x : v) x = value(rng);
    expectScalar(v, 0.0f);
  }
  expectScalar(std::vector<float>(5000, 2.5f), 2.5f);  // all background: not stored
  std::vector<float> almost(5000, 2.5f);
  almost[4999] = 2.0f;
  expectScalar(almost, 2.5f);
}

TEST(SampleRange, ZeroExtremesTakeTheFirstZerosSign) {
  for (const float first : {0.0f, -0.0f}) {
    std::vector<float> up(1000, 1.0f), down(1000, -1.0f);
    for (std::vector<float>* v : {&up, &down}) {
      (*v)[300] = first;  // lane 4 of its batch; the opposite sign comes later in an earlier lane
      (*v)[505] = -first;
      (*v)[999] = first;
      expectScalar(*v, 1.0f);
    }
    std::vector<float> zeros(100, first);  // a zero at sample 0
    zeros[50] = -first;
    expectScalar(zeros, 0.0f);
  }
}

TEST(SampleRange, NanFallsBackToTheScalarLoop) {
  std::vector<float> v(200, 1.0f);
  v[17] = 3.0f;
  v[90] = std::numeric_limits<float>::quiet_NaN();
  v[150] = -2.0f;
  expectScalar(v, 0.0f);
}

}  // namespace
}  // namespace voxbrick::store
