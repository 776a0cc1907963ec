// Basic value types of the brick store: voxel types, 3D sizes, brick keys.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>

#include "common/EnumNames.h"

namespace voxbrick::store {

/// The storage types a store can hold. Other input types are converted at ingest (see prep's README).
enum class ValueType : uint8_t { U8 = 0, U16 = 1, I16 = 2, F32 = 3 };

/// The value types' names: "u8", "u16", "i16", "f32", and the longer ones parseValueType also takes.
inline constexpr common::EnumName<ValueType> kValueTypeNames[] = {
    {ValueType::U8, "u8"},     {ValueType::U16, "u16"},   {ValueType::I16, "i16"},
    {ValueType::F32, "f32"},   {ValueType::U8, "uint8"},  {ValueType::U16, "uint16"},
    {ValueType::I16, "int16"}, {ValueType::F32, "float"}, {ValueType::F32, "float32"}};
constexpr std::span<const common::EnumName<ValueType>> enumNames(ValueType) { return kValueTypeNames; }

/// Bytes per voxel of a value type.
size_t valueSize(ValueType t);
/// "u8", "u16", "i16", "f32".
inline std::string_view valueTypeName(ValueType t) { return common::nameOf(t); }
/// Parses "u8"/"uint8"/..., throws InputError naming the bad text.
ValueType parseValueType(std::string_view name);

/// A size or index in voxels (or bricks) along x, y, z.
struct Vec3i {
  int64_t x = 0, y = 0, z = 0;
  int64_t volume() const { return x * y * z; }
  int64_t operator[](int a) const { return a == 0 ? x : (a == 1 ? y : z); }
  int64_t& operator[](int a) { return a == 0 ? x : (a == 1 ? y : z); }
  bool operator==(const Vec3i&) const = default;
};

/// Physical spacing of voxels along x, y, z.
struct Vec3d {
  double x = 1, y = 1, z = 1;
  double operator[](int a) const { return a == 0 ? x : (a == 1 ? y : z); }
  bool operator==(const Vec3d&) const = default;
};

/// Ceil(a / b) for positive b.
inline int64_t divUp(int64_t a, int64_t b) { return (a + b - 1) / b; }

/// Identifies one brick of one LOD level: brick (i, j, k) of level `level` covers voxels [i*B, (i+1)*B) etc.
struct BrickKey {
  uint32_t level = 0;
  uint32_t i = 0, j = 0, k = 0;
  bool operator==(const BrickKey&) const = default;
};

std::string toString(const BrickKey& key);

/// "256x256x128".
std::string dimsText(const Vec3i& dims);

/// Calls f(T{}) with T the C++ type of `t` (uint8_t, uint16_t, int16_t, float).
template <typename F>
decltype(auto) dispatchType(ValueType t, F&& f) {
  switch (t) {
    case ValueType::U8: return f(uint8_t{});
    case ValueType::U16: return f(uint16_t{});
    case ValueType::I16: return f(int16_t{});
    case ValueType::F32: break;
  }
  return f(float{});
}

}  // namespace voxbrick::store

template <>
struct std::hash<voxbrick::store::BrickKey> {
  size_t operator()(const voxbrick::store::BrickKey& key) const noexcept {
    uint64_t h = key.level;
    h = h * 0x9E3779B97F4A7C15ull ^ key.i;
    h = h * 0x9E3779B97F4A7C15ull ^ key.j;
    h = h * 0x9E3779B97F4A7C15ull ^ key.k;
    return static_cast<size_t>(h ^ (h >> 29));
  }
};
