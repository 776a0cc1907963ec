// The mesh store's blocks and files: byte-shuffled zstd frames (common/BlockCodec.h, the brick store's codec) with a
// CRC-32 of the compressed bytes, appended to a common::OutputFile, and a file read with pread. Every error is a
// MeshError naming the file and the block.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/OutputFile.h"
#include "mesh/MeshFormat.h"

namespace voxbrick::mesh {

/// Shuffles `bytes` bytes of 4-byte values into planes and compresses them into one zstd frame at `level`.
/// `bytes` must be a multiple of 4.
std::vector<char> encodeBlock(const void* values, size_t bytes, int level);

/// Throws MeshError(message): how the mesh store's output files (common::OutputFile) report a failed write.
[[noreturn]] void throwMeshError(const std::string& message);

/// Appends an encoded block to `file` and returns its BlockRef (offset, sizes, checksum); `rawSize` is its size
/// decoded.
BlockRef appendBlock(common::OutputFile& file, const std::vector<char>& encoded, uint64_t rawSize);

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
