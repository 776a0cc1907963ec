// Voxel type conversion: byte swap, scaling, widening to store types.
#include "brickstore/format/Convert.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <type_traits>
#include <utility>

#include "brickstore/format/Errors.h"
#include "brickstore/format/StoreMeta.h"

namespace voxbrick::store {
namespace {

template <typename T>
T loadValue(const unsigned char* p, bool swap) {
  using Bits = std::conditional_t<
      sizeof(T) == 1, uint8_t,
      std::conditional_t<sizeof(T) == 2, uint16_t, std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>>;
  Bits bits;
  std::memcpy(&bits, p, sizeof(bits));
  if (swap) {
    if constexpr (sizeof(T) == 2) bits = __builtin_bswap16(bits);
    if constexpr (sizeof(T) == 4) bits = __builtin_bswap32(bits);
    if constexpr (sizeof(T) == 8) bits = __builtin_bswap64(bits);
  }
  return std::bit_cast<T>(bits);
}

template <typename S, typename D, bool Scaled>
void convertValues(const Conversion& c, const void* src, void* dst, size_t count) {
  const auto* in = static_cast<const unsigned char*>(src);
  auto* out = static_cast<unsigned char*>(dst);
  for (size_t i = 0; i < count; ++i) {
    S v = loadValue<S>(in + i * sizeof(S), c.swapBytes);
    D d;
    if constexpr (Scaled) {
      d = static_cast<D>(static_cast<double>(v) * c.slope + c.inter);
    } else {
      d = static_cast<D>(v);
    }
    std::memcpy(out + i * sizeof(D), &d, sizeof(D));
  }
}

template <typename S, typename D>
void convertFrom(const Conversion& c, const void* src, void* dst, size_t count) {
  if (c.scaled)
    convertValues<S, float, true>(c, src, dst, count);
  else
    convertValues<S, D, false>(c, src, dst, count);
}

}  // namespace

size_t fileValueSize(FileValueType t) {
  switch (t) {
    case FileValueType::I8:
    case FileValueType::U8: return 1;
    case FileValueType::I16:
    case FileValueType::U16: return 2;
    case FileValueType::I32:
    case FileValueType::U32:
    case FileValueType::F32: return 4;
    case FileValueType::F64: return 8;
  }
  return 0;
}

ValueType storeTypeFor(FileValueType t) {
  switch (t) {
    case FileValueType::U8: return ValueType::U8;
    case FileValueType::U16: return ValueType::U16;
    case FileValueType::I8:
    case FileValueType::I16: return ValueType::I16;
    default: return ValueType::F32;
  }
}

bool Conversion::isIdentity() const {
  if (scaled) return false;
  if (swapBytes && fileValueSize(from) > 1) return false;
  return from == FileValueType::U8 || from == FileValueType::U16 || from == FileValueType::I16 ||
         from == FileValueType::F32;
}

void Conversion::apply(const void* src, void* dst, size_t count) const {
  switch (from) {
    case FileValueType::I8: convertFrom<int8_t, int16_t>(*this, src, dst, count); break;
    case FileValueType::U8: convertFrom<uint8_t, uint8_t>(*this, src, dst, count); break;
    case FileValueType::I16: convertFrom<int16_t, int16_t>(*this, src, dst, count); break;
    case FileValueType::U16: convertFrom<uint16_t, uint16_t>(*this, src, dst, count); break;
    case FileValueType::I32: convertFrom<int32_t, float>(*this, src, dst, count); break;
    case FileValueType::U32: convertFrom<uint32_t, float>(*this, src, dst, count); break;
    case FileValueType::F32: convertFrom<float, float>(*this, src, dst, count); break;
    case FileValueType::F64: convertFrom<double, float>(*this, src, dst, count); break;
  }
}

bool needsSwap(bool fileBigEndian) { return fileBigEndian != (std::endian::native == std::endian::big); }

int64_t checkedVolumeBytes(const Vec3i& dims, size_t valueBytes, const std::string& file) {
  if (dims.x <= 0 || dims.y <= 0 || dims.z <= 0) {
    throw InputError(file + ": zero or negative dims " + std::to_string(dims.x) + "," + std::to_string(dims.y) + "," +
                     std::to_string(dims.z));
  }
  int64_t bytes = 0;
  if (__builtin_mul_overflow(dims.x, dims.y, &bytes) || __builtin_mul_overflow(bytes, dims.z, &bytes) ||
      __builtin_mul_overflow(bytes, static_cast<int64_t>(valueBytes), &bytes)) {
    throw InputError(file + ": dims " + dimsText(dims) + " are too large (the volume's byte count overflows)");
  }
  return bytes;
}

void checkSpacing(const Vec3d& spacing, const std::string& file) {
  for (int a = 0; a < 3; ++a) {
    if (!spacingInRange(spacing[a])) {
      throw InputError(file + ": spacing " + std::to_string(spacing.x) + "," + std::to_string(spacing.y) + "," +
                       std::to_string(spacing.z) + " must be positive and finite, each in [1e-12, 1e12]");
    }
  }
}

std::string baseName(const std::string& path) {
  size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

}  // namespace voxbrick::store
