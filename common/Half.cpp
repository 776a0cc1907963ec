// Half floats back to floats, and rows of them either way with F16C where the processor has it (Half.h).
#include "common/Half.h"

#include <immintrin.h>

namespace voxbrick::common {
namespace {

// 8 values at a time, round to nearest even as floatToHalf; the tail value by value.
__attribute__((target("avx,f16c"))) void toHalvesF16c(const float* in, uint16_t* out, size_t count) {
  size_t i = 0;
  for (; i + 8 <= count; i += 8) {
    const __m128i packed = _mm256_cvtps_ph(_mm256_loadu_ps(in + i), _MM_FROUND_TO_NEAREST_INT);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i), packed);
  }
  for (; i < count; ++i) out[i] = floatToHalf(in[i]);
}

__attribute__((target("avx,f16c"))) void toFloatsF16c(const uint16_t* in, float* out, size_t count) {
  size_t i = 0;
  for (; i + 8 <= count; i += 8) {
    const __m128i packed = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + i));
    _mm256_storeu_ps(out + i, _mm256_cvtph_ps(packed));
  }
  for (; i < count; ++i) out[i] = halfToFloat(in[i]);
}

const bool kF16c = __builtin_cpu_supports("f16c") && __builtin_cpu_supports("avx");

}  // namespace

float halfToFloat(uint16_t half) {
  const uint32_t sign = uint32_t(half & 0x8000u) << 16;
  const uint32_t exponent = (half >> 10) & 0x1fu;
  uint32_t mantissa = half & 0x3ffu;
  uint32_t bits;
  if (exponent == 0) {
    if (mantissa == 0) {
      bits = sign;
    } else {  // subnormal: normalise
      int e = -1;
      do {
        ++e;
        mantissa <<= 1;
      } while ((mantissa & 0x400u) == 0);
      bits = sign | uint32_t(127 - 15 - e) << 23 | (mantissa & 0x3ffu) << 13;
    }
  } else if (exponent == 31) {
    bits = sign | 0x7f800000u | mantissa << 13;
  } else {
    bits = sign | (exponent + 112u) << 23 | mantissa << 13;
  }
  float value;
  std::memcpy(&value, &bits, 4);
  return value;
}

void floatsToHalves(const float* in, uint16_t* out, size_t count) {
  if (kF16c) return toHalvesF16c(in, out, count);
  for (size_t i = 0; i < count; ++i) out[i] = floatToHalf(in[i]);
}

void halvesToFloats(const uint16_t* in, float* out, size_t count) {
  if (kF16c) return toFloatsF16c(in, out, count);
  for (size_t i = 0; i < count; ++i) out[i] = halfToFloat(in[i]);
}

}  // namespace voxbrick::common
