// What the numbers and names of the VTK legacy format mean: data types, cell types, escaped array names.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace voxbrick::mesh {

enum class VtkType { Bit, Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64, String };

struct VtkTypeInfo {
  const char* name;
  VtkType type;
  uint32_t bytes;  ///< in binary files; 0 for bit and string arrays
};

/// The data type named `lowerCaseName` ("float", "vtktypeint64", ...), or nullptr.
const VtkTypeInfo* findVtkType(std::string_view lowerCaseName);

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
