// The mesh store's blocks and files: byte-shuffled zstd frames with a CRC-32 of the compressed bytes, a file written
// by appending and fsynced, and a file read with pread. Every error is a MeshError naming the file and the block.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mesh/MeshFormat.h"

namespace voxbrick::mesh {

/// Shuffles `bytes` bytes of 4-byte values into planes and compresses them into one zstd frame at `level`.
/// `bytes` must be a multiple of 4.
std::vector<char> encodeBlock(const void* values, size_t bytes, int level);

/// A file created (or truncated) for writing whose every failed write throws MeshError naming it.
class MeshOutputFile {
 public:
  explicit MeshOutputFile(const std::filesystem::path& path);
  ~MeshOutputFile();
  MeshOutputFile(const MeshOutputFile&) = delete;
  MeshOutputFile& operator=(const MeshOutputFile&) = delete;

  /// Appends `size` bytes; returns the offset they start at.
  uint64_t append(const void* data, size_t size);
  /// Appends an encoded block and returns its BlockRef (offset, sizes, checksum); `rawSize` is its size decoded.
  BlockRef appendBlock(const std::vector<char>& encoded, uint64_t rawSize);
  uint64_t size() const { return mSize; }
  /// Flushes to disk (fsync) and closes; throws MeshError on failure.
  void close();

 private:
  std::filesystem::path mPath;
  int mFd = -1;
  uint64_t mSize = 0;
};

/// A file opened read-only; reads are pread on one descriptor, so a const reader is safe to share between threads.
class MeshInputFile {
 public:
  MeshInputFile() = default;
  /// Opens `path`; throws MeshError if it is missing or unreadable.
  explicit MeshInputFile(const std::filesystem::path& path);
  ~MeshInputFile();
  MeshInputFile(MeshInputFile&& other) noexcept;
  MeshInputFile& operator=(MeshInputFile&& other) noexcept;

  uint64_t size() const { return mSize; }
  const std::filesystem::path& path() const { return mPath; }
  /// Reads exactly `size` bytes at `offset`; throws MeshError on a short read.
  void readAt(uint64_t offset, void* dst, size_t size) const;
  /// Reads the block `ref`, checks its CRC-32, decompresses and unshuffles it into dst, which holds `rawSize` bytes
  /// (the size the caller expects from the counts; the block must agree). `what` names the block in errors.
  void readBlock(const BlockRef& ref, void* dst, uint64_t rawSize, const std::string& what) const;

 private:
  std::filesystem::path mPath;
  int mFd = -1;
  uint64_t mSize = 0;
};

/// Checks a BlockRef read from an index against the data file's size and the size its counts give, before anything
/// is allocated from it; throws MeshError "<where>: <what> ..." when it cannot be right.
void checkBlockRef(const BlockRef& ref, uint64_t dataFileSize, uint64_t expectedRawSize, const std::string& where,
                   const std::string& what);

}  // namespace voxbrick::mesh
