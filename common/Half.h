// IEEE 754 half floats (binary16): the one conversion the brick atlas' Half format and the compositor's half-float
// pixel encoding share, so that both round alike.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace voxbrick::common {

/// The half nearest `value`, ties to even (as IEEE 754, Mesa's conversion and F16C do): overflow to infinity,
/// infinities kept, NaN a quiet NaN of the same sign (payload dropped), subnormal halves where the value is that
/// small. Inline: the atlas converts every voxel of a Half brick through it.
inline uint16_t floatToHalf(float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, 4);
  const uint16_t sign = uint16_t((bits >> 16) & 0x8000u);
  const uint32_t magnitude = bits & 0x7fffffffu;
  if (magnitude >= 0x7f800000u) return uint16_t(sign | (magnitude > 0x7f800000u ? 0x7e00u : 0x7c00u));
  if (magnitude >= 0x477ff000u) return uint16_t(sign | 0x7c00u);  // rounds to 65536 or more: infinity
  if (magnitude < 0x38800000u) {                                  // below 2^-14: a subnormal half (or zero)
    if (magnitude < 0x33000000u) return sign;                     // below 2^-25: rounds to zero
    const uint32_t mantissa = (magnitude & 0x7fffffu) | 0x800000u;
    const int shift = 126 - int(magnitude >> 23);  // 14 .. 24 places right of the half's ulp
    const uint32_t half = mantissa >> shift, rest = mantissa & ((1u << shift) - 1), mid = 1u << (shift - 1);
    return uint16_t(sign | (half + ((rest > mid || (rest == mid && (half & 1u))) ? 1u : 0u)));
  }
  const uint32_t rebiased = magnitude - 0x38000000u;  // exponent 127 -> 15
  const uint32_t half = rebiased >> 13, rest = rebiased & 0x1fffu;
  return uint16_t(sign | (half + ((rest > 0x1000u || (rest == 0x1000u && (half & 1u))) ? 1u : 0u)));
}

/// The float a half stands for (exact: every half is a float).
float halfToFloat(uint16_t half);

/// floatToHalf over `count` values, with the F16C instructions where the processor has them (the same halves but
/// for NaN payloads, which F16C keeps).
void floatsToHalves(const float* in, uint16_t* out, size_t count);
/// halfToFloat over `count` values, with F16C where the processor has it.
void halvesToFloats(const uint16_t* in, float* out, size_t count);

/// A half float as a value type (its bits), made from any arithmetic value by floatToHalf(float(value)): what a
/// converting copy writes into a GL_HALF_FLOAT texture.
struct Half {
  uint16_t bits = 0;
  Half() = default;
  template <typename T>
  explicit Half(T value) : bits(floatToHalf(float(value))) {}
};
static_assert(sizeof(Half) == 2);

}  // namespace voxbrick::common
