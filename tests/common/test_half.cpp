// common/Half.h: the rounding both the atlas' Half format and the compositor's half pixels rely on.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "common/Half.h"

namespace voxbrick::common {
namespace {

TEST(Half, RoundsToNearestTiesToEven) {
  EXPECT_EQ(floatToHalf(1.0f), 0x3c00);
  EXPECT_EQ(floatToHalf(-2.0f), 0xc000);
  EXPECT_EQ(floatToHalf(65504.0f), 0x7bff);
  // 1 + 2^-11 lies halfway between 1 and the next half: ties to the even one (1); 1 + 3 * 2^-11 to 1 + 2^-9.
  EXPECT_EQ(floatToHalf(1.0f + std::ldexp(1.0f, -11)), 0x3c00);
  EXPECT_EQ(floatToHalf(1.0f + 3 * std::ldexp(1.0f, -11)), 0x3c02);
  EXPECT_EQ(floatToHalf(1.0f + std::ldexp(1.0f, -11) + std::ldexp(1.0f, -20)), 0x3c01);
}

TEST(Half, KeepsTheEdges) {
  EXPECT_EQ(floatToHalf(65520.0f), 0x7c00);  // halfway to 65536: rounds to infinity
  EXPECT_EQ(floatToHalf(std::numeric_limits<float>::infinity()), 0x7c00);
  EXPECT_EQ(floatToHalf(-std::numeric_limits<float>::infinity()), 0xfc00);
  EXPECT_EQ(floatToHalf(std::numeric_limits<float>::quiet_NaN()), 0x7e00);
  EXPECT_EQ(floatToHalf(std::ldexp(1.0f, -24)), 0x0001);  // the smallest subnormal
  EXPECT_EQ(floatToHalf(std::ldexp(1.0f, -25)), 0x0000);  // half of it: ties to even zero
  EXPECT_EQ(floatToHalf(-0.0f), 0x8000);
  EXPECT_TRUE(std::isnan(halfToFloat(0x7e00)));
}

TEST(Half, EveryHalfComesBackExactly) {
  for (uint32_t h = 0; h < 0x10000; ++h) {
    if ((h & 0x7c00u) == 0x7c00u && (h & 0x3ffu)) continue;  // NaN payloads
    ASSERT_EQ(floatToHalf(halfToFloat(uint16_t(h))), h) << std::hex << h;
  }
  EXPECT_EQ(halfToFloat(0x0001), std::ldexp(1.0f, -24));
  EXPECT_EQ(halfToFloat(0x3555), 0.333251953125f);
}

TEST(Half, RowsRoundAsTheScalar) {
  std::vector<float> in;
  for (int i = 0; i < 1000; ++i) in.push_back(std::ldexp(float(i) * 0.7391f - 350.0f, i % 40 - 30));
  std::vector<uint16_t> halves(in.size());
  floatsToHalves(in.data(), halves.data(), in.size());
  std::vector<float> back(in.size());
  halvesToFloats(halves.data(), back.data(), halves.size());
  for (size_t i = 0; i < in.size(); ++i) {
    ASSERT_EQ(halves[i], floatToHalf(in[i])) << in[i];
    ASSERT_EQ(back[i], halfToFloat(halves[i]));
  }
  EXPECT_EQ(Half(uint8_t(255)).bits, floatToHalf(255.0f));
}

}  // namespace
}  // namespace voxbrick::common
