// Sequential reading of a file's bytes from an offset, plain or gzip-compressed, with bounded memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace voxbrick::store {

/// Reads a file in order from a byte offset, inflating it on the fly when it is gzip (or zlib) compressed.
/// Memory stays bounded by one input chunk, whatever the file's size.
class ByteStream {
 public:
  /// How the bytes from the offset on are stored.
  enum class Compression { None, Gzip };

  /// Opens `path` at byte `offset`; throws IoError when the file cannot be opened.
  ByteStream(const std::string& path, int64_t offset, Compression compression);
  ~ByteStream();
  ByteStream(const ByteStream&) = delete;
  ByteStream& operator=(const ByteStream&) = delete;

  /// Reads exactly n (decoded) bytes. Throws InputError "<file>: truncated: ..." when the data ends first and
  /// "<file>: corrupt gzip data (...)" when inflate fails.
  void readExact(void* dst, size_t n);

  /// Reads up to n bytes, fewer only where the data ends; returns how many were read.
  size_t readUpTo(void* dst, size_t n);

  /// Discards the next n decoded bytes; throws like readExact() when the data ends first.
  void skip(uint64_t n);

  /// For gzip data, inflates to the end of the current member so that its CRC is checked even though the caller
  /// has all the bytes it wants (extra decoded bytes are discarded); throws like readExact(). No-op for plain data.
  void verifyEnd();

  /// Decoded bytes delivered (or skipped) so far.
  uint64_t position() const { return mPosition; }

 private:
  size_t readPlain(void* dst, size_t n);
  size_t readGzip(void* dst, size_t n);
  void fillInput();
  [[noreturn]] void throwTruncated(size_t expected, size_t got, const char* what) const;
  [[noreturn]] void throwCorrupt(int zlibCode) const;

  struct Inflater;
  std::string mPath;
  int mFd = -1;
  int64_t mFileOffset = 0;  // next byte of the file to read
  uint64_t mPosition = 0;
  Compression mCompression;
  std::unique_ptr<Inflater> mInflater;
};

/// Size of a file in bytes; throws IoError when it cannot be examined.
int64_t fileSize(const std::string& path);

/// True when the file starts with the gzip magic bytes 1f 8b.
bool isGzipFile(const std::string& path);

/// The first maxBytes bytes of a file (fewer if it is shorter), inflated first when it is gzip-compressed;
/// for headers.
std::vector<char> readFilePrefix(const std::string& path, size_t maxBytes);

/// A volume's `dataBytes` bytes of voxel data in `path`, `skip` bytes after byte `start`: inflated from `start` (the
/// skip counted in decoded bytes) when `gzip`; else read in place once the file is known to hold them all, where a
/// skip of -1 means the file's last `dataBytes` bytes. Throws InputError "<file>: truncated: ..." when it is short.
std::unique_ptr<ByteStream> openVoxelData(const std::string& path, int64_t start, int64_t skip, bool gzip,
                                          int64_t dataBytes);

/// The file offset just after `lines` newline characters counted from `offset`. Throws InputError when the file
/// ends first.
int64_t offsetAfterLines(const std::string& path, int64_t offset, int64_t lines);

}  // namespace voxbrick::store
