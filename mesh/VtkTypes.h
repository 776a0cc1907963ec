// What the numbers and names of the VTK legacy format mean: data types, cell types, escaped array names.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "common/EnumNames.h"

namespace voxbrick::mesh {

enum class VtkType { Bit, Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64, String };

/// The data types by the names files give them (lower case), several names for most: common::valueOf<VtkType>.
inline constexpr common::EnumName<VtkType> kVtkTypeNames[] = {
    {VtkType::Bit, "bit"},
    {VtkType::Int8, "char"},
    {VtkType::Int8, "signed_char"},
    {VtkType::UInt8, "unsigned_char"},
    {VtkType::Int16, "short"},
    {VtkType::UInt16, "unsigned_short"},
    {VtkType::Int32, "int"},
    {VtkType::UInt32, "unsigned_int"},
    // "long" has the writer's sizeof(long): 8 on the LP64 systems that write nearly all such files.
    {VtkType::Int64, "long"},
    {VtkType::UInt64, "unsigned_long"},
    {VtkType::Int64, "vtkidtype"},
    {VtkType::Int8, "vtktypeint8"},
    {VtkType::UInt8, "vtktypeuint8"},
    {VtkType::Int16, "vtktypeint16"},
    {VtkType::UInt16, "vtktypeuint16"},
    {VtkType::Int32, "vtktypeint32"},
    {VtkType::UInt32, "vtktypeuint32"},
    {VtkType::Int64, "vtktypeint64"},
    {VtkType::UInt64, "vtktypeuint64"},
    {VtkType::Float32, "float"},
    {VtkType::Float64, "double"},
    {VtkType::Float32, "vtktypefloat32"},
    {VtkType::Float64, "vtktypefloat64"},
    {VtkType::String, "string"},
    {VtkType::String, "utf8_string"}};
constexpr std::span<const common::EnumName<VtkType>> enumNames(VtkType) { return kVtkTypeNames; }

/// Bytes of a value in binary files; 0 for bit and string arrays.
uint32_t vtkTypeBytes(VtkType type);

inline constexpr int kVtkTetra = 10;

/// A VTK cell type (vtkCellType.h): its name and dimension.
struct VtkCellKind {
  const char* name;
  int dim;
};

/// The cell type numbered `type`, or nullopt when VTK has no such type.
std::optional<VtkCellKind> vtkCellKind(int64_t type);

/// A name as VTK 7+ writes it, with spaces, '%' and unprintable bytes as %XX.
std::string encodeVtkName(std::string_view name);
/// The name an encoded one stands for (text without escapes comes back unchanged).
std::string decodeVtkName(std::string_view text);

}  // namespace voxbrick::mesh
