// Voxel type conversion (byte swap, scaling, widening to store types) and the dense streaming source.
#include "brickstore/Convert.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <type_traits>
#include <utility>

#include "brickstore/Errors.h"
#include "brickstore/StoreMeta.h"

namespace voxbrick::store {
namespace {

// Conversion works through a bounded staging buffer so that memory does not grow with the slices asked for.
constexpr size_t kStagingBytes = size_t(1) << 20;

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

std::string_view fileValueTypeName(FileValueType t) {
  switch (t) {
    case FileValueType::I8: return "int8";
    case FileValueType::U8: return "uint8";
    case FileValueType::I16: return "int16";
    case FileValueType::U16: return "uint16";
    case FileValueType::I32: return "int32";
    case FileValueType::U32: return "uint32";
    case FileValueType::F32: return "float";
    case FileValueType::F64: return "double";
  }
  return "?";
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

void checkSliceFitsMemory(int64_t nx, int64_t ny, size_t valueBytes, const SourceOptions& options,
                          const std::string& file, const std::string& field) {
  if (options.memoryBudgetMB <= 0) return;
  constexpr double kProcessMB = 112;  // an idle voxbrick, as StoreWriter's memory plan counts it
  const double sliceMB = double(nx) * double(ny) * double(valueBytes) / double(1 << 20);
  if (2 * sliceMB + kProcessMB <= double(options.memoryBudgetMB)) return;
  char text[160];
  std::snprintf(text, sizeof text, " declares slices of %lldx%lld voxels of %zu bytes (%.0f MB each): --memory %lld MB",
                static_cast<long long>(nx), static_cast<long long>(ny), valueBytes, sliceMB,
                static_cast<long long>(options.memoryBudgetMB));
  throw InputError(file + ": " + field + text + " is too small (it needs at least " +
                   std::to_string(static_cast<long long>(std::ceil(2 * sliceMB + kProcessMB))) + " MB)");
}

void checkSpacing(const Vec3d& spacing, const std::string& file) {
  for (int a = 0; a < 3; ++a) {
    if (!spacingInRange(spacing[a])) {
      throw InputError(file + ": spacing " + std::to_string(spacing.x) + "," + std::to_string(spacing.y) + "," +
                       std::to_string(spacing.z) + " must be positive and finite, each in [1e-12, 1e12]");
    }
  }
}

std::string dimsText(const Vec3i& dims) {
  return std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" + std::to_string(dims.z);
}

std::string baseName(const std::string& path) {
  size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

DenseSource::DenseSource(VolumeInfo info, std::unique_ptr<ByteStream> stream, Conversion conversion, std::string file)
    : mInfo(std::move(info)), mStream(std::move(stream)), mConversion(conversion), mFile(std::move(file)) {
  if (mInfo.type != mConversion.to()) {
    throw StoreError(mFile + ": internal error: source type " + std::string(valueTypeName(mInfo.type)) +
                     " does not match the conversion's " + std::string(valueTypeName(mConversion.to())));
  }
}

void DenseSource::readSlices(int64_t count, void* dst) {
  if (count < 0) throw InputError(mFile + ": negative slice count " + std::to_string(count));
  if (count > mInfo.dims.z - mNextZ) {
    throw InputError(mFile + ": read past the end of the volume: asked for z-slices " + std::to_string(mNextZ) + ".." +
                     std::to_string(mNextZ + count - 1) + " but dims.z is " + std::to_string(mInfo.dims.z));
  }
  const size_t values = static_cast<size_t>(count * mInfo.dims.x * mInfo.dims.y);
  const size_t inSize = fileValueSize(mConversion.from);
  const size_t outSize = valueSize(mInfo.type);
  auto* out = static_cast<unsigned char*>(dst);
  // A short read reports what the whole rest of the volume lacks, not just this chunk.
  auto readOrThrow = [&](void* into, size_t bytes, size_t doneBytes) {
    size_t got = mStream->readUpTo(into, bytes);
    if (got == bytes) return;
    const int64_t remaining = (mInfo.dims.z - mNextZ) * mInfo.dims.x * mInfo.dims.y * static_cast<int64_t>(inSize);
    throw InputError(mFile + ": truncated: expected " + std::to_string(remaining) + " more bytes of voxel data, got " +
                     std::to_string(doneBytes + got));
  };
  if (mConversion.isIdentity()) {
    readOrThrow(out, values * inSize, 0);
  } else {
    const size_t chunk = std::max<size_t>(1, kStagingBytes / inSize);
    mBuffer.resize(std::min(values, chunk) * inSize);
    for (size_t done = 0; done < values;) {
      size_t n = std::min(values - done, chunk);
      readOrThrow(mBuffer.data(), n * inSize, done * inSize);
      mConversion.apply(mBuffer.data(), out + done * outSize, n);
      done += n;
    }
  }
  mNextZ += count;
  if (mNextZ == mInfo.dims.z) mStream->verifyEnd();
}

}  // namespace voxbrick::store
