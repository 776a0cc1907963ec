// Raw voxel files: everything about the volume comes from the options, the file holds only the voxels.
#include <memory>

#include "brickstore/format/Convert.h"
#include "brickstore/format/Errors.h"
#include "brickstore/ingest/raw/DenseSource.h"
#include "brickstore/ingest/raw/RawSources.h"
#include "brickstore/source/ByteStream.h"

namespace voxbrick::store {
namespace {

FileValueType fileTypeOf(ValueType t) {
  switch (t) {
    case ValueType::U8: return FileValueType::U8;
    case ValueType::U16: return FileValueType::U16;
    case ValueType::I16: return FileValueType::I16;
    case ValueType::F32: return FileValueType::F32;
  }
  return FileValueType::U8;
}

std::string optionsText(const SourceOptions& options) {
  std::string text = "--dims " + std::to_string(options.dims.x) + "," + std::to_string(options.dims.y) + "," +
                     std::to_string(options.dims.z) + " --type " + options.type;
  if (options.headerBytes != 0) text += " --header-bytes " + std::to_string(options.headerBytes);
  return text;
}

}  // namespace

std::unique_ptr<VolumeSource> openRawSource(const std::string& path, const SourceOptions& options) {
  if (options.type.empty()) throw InputError(path + ": raw input needs --type (u8, u16, i16 or f32)");
  ValueType type;
  try {
    type = parseValueType(options.type);
  } catch (const InputError& e) {
    throw InputError(path + ": " + e.what());
  }
  const int64_t voxelBytes = checkedVolumeBytes(options.dims, valueSize(type), path);
  checkSliceFitsMemory(options.dims.x, options.dims.y, valueSize(type), options, path, "--dims");
  if (options.headerBytes < 0) {
    throw InputError(path + ": negative --header-bytes " + std::to_string(options.headerBytes));
  }
  int64_t expected = 0;
  if (__builtin_add_overflow(voxelBytes, options.headerBytes, &expected)) {
    throw InputError(path + ": " + optionsText(options) + " describes more bytes than a file can hold");
  }
  const int64_t actual = fileSize(path);
  if (actual != expected) {
    throw InputError(path + ": size " + std::to_string(actual) + " bytes does not match " + optionsText(options) +
                     " (expected " + std::to_string(expected) + " bytes)");
  }

  VolumeInfo info;
  info.dims = options.dims;
  info.spacing = options.spacingGiven ? options.spacing : Vec3d{1, 1, 1};
  checkSpacing(info.spacing, path);
  info.type = type;
  info.background = 0.0;
  info.description = "raw " + std::string(valueTypeName(type)) + (options.bigEndian ? " big-endian " : " ") +
                     dimsText(info.dims) + " (" + baseName(path) + ")";

  Conversion conversion;
  conversion.from = fileTypeOf(type);
  conversion.swapBytes = needsSwap(options.bigEndian);
  auto stream = std::make_unique<ByteStream>(path, options.headerBytes, ByteStream::Compression::None);
  auto source = std::make_unique<DenseSource>(std::move(info), std::move(stream), conversion, path);
  source->setReopen([path, options] { return openRawSource(path, options); });
  return source;
}

}  // namespace voxbrick::store
