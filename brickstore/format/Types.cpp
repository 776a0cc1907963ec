// Value-type helpers and error formatting shared by the whole brick store.
#include "brickstore/format/Types.h"

#include <cerrno>
#include <cstring>
#include <optional>

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

ValueType parseValueType(std::string_view name) {
  if (const std::optional<ValueType> type = common::valueOf<ValueType>(name)) return *type;
  throw InputError("unsupported voxel type '" + std::string(name) + "' (expected " +
                   common::enumNamesText<ValueType>() + ")");
}

std::string toString(const BrickKey& key) {
  return "brick (level " + std::to_string(key.level) + ", " + std::to_string(key.i) + ", " + std::to_string(key.j) +
         ", " + std::to_string(key.k) + ")";
}

std::string dimsText(const Vec3i& dims) {
  return std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" + std::to_string(dims.z);
}

std::string errnoMessage(const std::string& what) { return what + ": " + std::strerror(errno); }

void throwIoError(const std::string& message) { throw IoError(message); }

}  // namespace voxbrick::store
