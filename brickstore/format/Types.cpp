// Value-type helpers and error formatting shared by the whole brick store.
#include "brickstore/format/Types.h"

#include <cerrno>
#include <cstring>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {

size_t valueSize(ValueType t) {
  switch (t) {
    case ValueType::U8: return 1;
    case ValueType::U16: return 2;
    case ValueType::I16: return 2;
    case ValueType::F32: return 4;
  }
  return 0;
}

std::string_view valueTypeName(ValueType t) {
  switch (t) {
    case ValueType::U8: return "u8";
    case ValueType::U16: return "u16";
    case ValueType::I16: return "i16";
    case ValueType::F32: return "f32";
  }
  return "?";
}

ValueType parseValueType(std::string_view name) {
  if (name == "u8" || name == "uint8") return ValueType::U8;
  if (name == "u16" || name == "uint16") return ValueType::U16;
  if (name == "i16" || name == "int16") return ValueType::I16;
  if (name == "f32" || name == "float" || name == "float32") return ValueType::F32;
  throw InputError("unsupported voxel type '" + std::string(name) + "' (expected u8, u16, i16 or f32)");
}

std::string toString(const BrickKey& key) {
  return "brick (level " + std::to_string(key.level) + ", " + std::to_string(key.i) + ", " + std::to_string(key.j) +
         ", " + std::to_string(key.k) + ")";
}

std::string dimsText(const Vec3i& dims) {
  return std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" + std::to_string(dims.z);
}

std::string errnoMessage(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace voxbrick::store
