// bricks.bin: appending zstd frames while writing, and reading them back by record with pread.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "brickstore/format/StoreFormat.h"
#include "brickstore/format/Types.h"

namespace voxbrick::store {

/// A file opened for writing whose every failed write (full disk, file too large) throws IoError naming it.
class OutputFile {
 public:
  /// Creates or truncates `path`; throws IoError if it cannot.
  explicit OutputFile(const std::filesystem::path& path);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  /// Appends bytes; returns the offset they start at.
  uint64_t append(const void* data, size_t size);
  uint64_t size() const { return mSize; }
  /// Flushes to disk (fsync) and closes; throws IoError on failure.
  void close();

 private:
  std::filesystem::path mPath;
  int mFd = -1;
  uint64_t mSize = 0;
};

/// Reads and decodes brick frames from a bricks file. Thread-safe (pread on a shared descriptor).
class BrickFileReader {
 public:
  BrickFileReader() = default;
  /// Opens `path`, whose frames hold values of `type`, read-only; throws IoError.
  BrickFileReader(const std::filesystem::path& path, ValueType type);
  ~BrickFileReader();
  BrickFileReader(BrickFileReader&& other) noexcept;
  BrickFileReader& operator=(BrickFileReader&& other) noexcept;

  /// Decodes the frame of `record` into dst (`bytes` bytes). `key` names the brick in errors.
  void decode(const BrickRecord& record, const BrickKey& key, void* dst, size_t bytes) const;
  /// Like decode, but a brick that is not stored (size 0) is filled with `background` without I/O.
  void read(const BrickRecord& record, const BrickKey& key, void* dst, size_t bytes, double background) const;
  uint64_t fileSize() const;
  const std::filesystem::path& path() const { return mPath; }

 private:
  std::filesystem::path mPath;
  ValueType mType = ValueType::F32;
  size_t mElementSize = 1;
  int mFd = -1;
};

/// Fills `count` values of type `type` at dst with `value` (converted to the type).
void fillValue(ValueType type, double value, void* dst, size_t count);

}  // namespace voxbrick::store
