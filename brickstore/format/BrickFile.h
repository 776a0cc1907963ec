// bricks.bin: its frames (common/BlockCodec.h, with the brick store's settings and words), and reading them back by
// record with pread. Prep appends them through common::OutputFile.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "brickstore/format/StoreFormat.h"
#include "brickstore/format/Types.h"

namespace voxbrick::store {

/// Compresses `size` bytes at src into one frame (zstd, with its content checksum); dst is replaced. Values of
/// elementSize 2 or 4 are shuffled into byte planes first; at level 1, 4-byte values keep their literals as they are
/// (on float bricks, planes of mantissa noise, Huffman coding them costs a third of the compression time for 0.3 % of
/// the bytes; not for 8- and 16-bit values, where it saves a quarter of the bytes of an MRI).
void compressFrame(const void* src, size_t size, size_t elementSize, int level, std::vector<char>& dst);

/// Decompresses one frame written by compressFrame with the same elementSize into exactly `expectedSize` bytes at
/// dst. Throws CorruptStoreError mentioning `what` when the frame is corrupt, fails its checksum, or decodes to a
/// different size.
void decompressFrame(const void* src, size_t size, size_t elementSize, void* dst, size_t expectedSize,
                     const std::string& what);

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
