// Conversion of file voxel types to store types, shared by the readers of dense files and of OME-Zarr chunks, and
// the checks of the sizes and spacing their headers declare.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "brickstore/format/Types.h"
#include "common/EnumNames.h"

namespace voxbrick::store {

/// The scalar voxel types that dense input files may hold.
enum class FileValueType : uint8_t { I8, U8, I16, U16, I32, U32, F32, F64 };

inline constexpr common::EnumName<FileValueType> kFileValueTypeNames[] = {
    {FileValueType::I8, "int8"},    {FileValueType::U8, "uint8"},  {FileValueType::I16, "int16"},
    {FileValueType::U16, "uint16"}, {FileValueType::I32, "int32"}, {FileValueType::U32, "uint32"},
    {FileValueType::F32, "float"},  {FileValueType::F64, "double"}};
constexpr std::span<const common::EnumName<FileValueType>> enumNames(FileValueType) { return kFileValueTypeNames; }

/// Bytes per voxel of a file value type.
size_t fileValueSize(FileValueType t);
/// "int8", "uint8", "int16", "uint16", "int32", "uint32", "float", "double".
inline std::string_view fileValueTypeName(FileValueType t) { return common::nameOf(t); }
/// The store type a file type is kept as: u8, u16 and i16 as themselves, int8 widened to i16, the rest f32.
ValueType storeTypeFor(FileValueType t);

/// How to turn values read from a file into store values.
struct Conversion {
  FileValueType from = FileValueType::U8;
  bool swapBytes = false;  ///< the file's byte order differs from the host's
  bool scaled = false;     ///< apply v * slope + inter (the result is always f32)
  double slope = 1.0;
  double inter = 0.0;

  /// The store type produced.
  ValueType to() const { return scaled ? ValueType::F32 : storeTypeFor(from); }
  /// True when the file bytes already are the store bytes.
  bool isIdentity() const;
  /// Converts `count` values from src (file layout, any alignment) to dst (store type).
  void apply(const void* src, void* dst, size_t count) const;
};

/// True when a file in the given byte order must be swapped on this host.
bool needsSwap(bool fileBigEndian);

/// Bytes of a dims volume of `valueBytes`-byte values; throws InputError naming `file` when a dimension is not
/// positive or the product overflows.
int64_t checkedVolumeBytes(const Vec3i& dims, size_t valueBytes, const std::string& file);

/// Throws InputError naming `file` unless every component is a spacing in [kMinSpacing, kMaxSpacing] (positive, finite,
/// and within what a world transform can invert).
void checkSpacing(const Vec3d& spacing, const std::string& file);

/// The file name without its directories, for descriptions.
std::string baseName(const std::string& path);

}  // namespace voxbrick::store
