// A file written by appending, the one output file of both stores (bricks.bin and the brick store's index and
// metadata; the mesh store's files) and of prep's scratch files.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace voxbrick::common {

/// A file created (or truncated) for writing. Writes go straight to the descriptor, so that a full disk (ENOSPC) or a
/// file too large (EFBIG) surfaces at the write that hit it; every failure is reported through `fail`, with a message
/// naming the file, so that each store throws its own error (the brick store's IoError, the mesh store's MeshError).
class OutputFile {
 public:
  /// Throws the caller's error with `message`; must not return.
  using Fail = void (*)(const std::string& message);

  /// Creates or truncates `path`; reports "cannot create PATH: REASON" if it cannot.
  OutputFile(const std::filesystem::path& path, Fail fail);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  /// Appends `size` bytes; returns the offset they start at.
  uint64_t append(const void* data, size_t size);
  uint64_t size() const { return mSize; }
  /// Flushes to disk (fsync) and closes; reports a failure of either.
  void close();

 private:
  [[noreturn]] void report(const std::string& what) const;

  std::filesystem::path mPath;
  Fail mFail;
  int mFd = -1;
  uint64_t mSize = 0;
};

}  // namespace voxbrick::common
