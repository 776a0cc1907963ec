// Blocks and files of the mesh store. Writes go straight to the descriptor so that ENOSPC/EFBIG surface at the block
// that hit them; reads are pread so that chunks can be paged from several threads.
#include "mesh/MeshBlocks.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "common/Checksum.h"
#include "mesh/TetMesh.h"

namespace voxbrick::mesh {
namespace {

std::string errnoText(const std::string& what) { return what + ": " + std::strerror(errno); }

/// Byte planes: the sign/exponent bytes of floats and the high bytes of indices repeat, so they compress far better
/// apart from the noisy low bytes.
void shuffle4(const char* src, char* dst, size_t count) {
  for (size_t i = 0; i < count; ++i)
    for (size_t b = 0; b < 4; ++b) dst[b * count + i] = src[i * 4 + b];
}

void unshuffle4(const char* src, char* dst, size_t count) {
  for (size_t i = 0; i < count; ++i)
    for (size_t b = 0; b < 4; ++b) dst[i * 4 + b] = src[b * count + i];
}

}  // namespace

std::vector<char> encodeBlock(const void* values, size_t bytes, int level) {
  if (bytes % 4 != 0)
    throw MeshError("encodeBlock: " + std::to_string(bytes) + " bytes is not a whole number of values");
  std::vector<char> planes(bytes);
  shuffle4(static_cast<const char*>(values), planes.data(), bytes / 4);
  std::vector<char> out(ZSTD_compressBound(bytes));
  const size_t n = ZSTD_compress(out.data(), out.size(), planes.data(), planes.size(), level);
  if (ZSTD_isError(n)) throw MeshError(std::string("encodeBlock: zstd failed: ") + ZSTD_getErrorName(n));
  out.resize(n);
  return out;
}

MeshOutputFile::MeshOutputFile(const std::filesystem::path& path) : mPath(path) {
  mFd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (mFd < 0) throw MeshError(errnoText("cannot create " + path.string()));
}

MeshOutputFile::~MeshOutputFile() {
  if (mFd >= 0) ::close(mFd);
}

uint64_t MeshOutputFile::append(const void* data, size_t size) {
  const uint64_t start = mSize;
  const char* p = static_cast<const char*>(data);
  size_t left = size;
  while (left > 0) {
    const ssize_t n = ::write(mFd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw MeshError(errnoText("write to " + mPath.string() + " failed"));
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  mSize += size;
  return start;
}

BlockRef MeshOutputFile::appendBlock(const std::vector<char>& encoded, uint64_t rawSize) {
  BlockRef ref{};
  ref.compressedSize = encoded.size();
  ref.rawSize = rawSize;
  ref.crc32 = common::crc32Of(encoded.data(), encoded.size());
  ref.offset = append(encoded.data(), encoded.size());
  return ref;
}

void MeshOutputFile::close() {
  if (mFd < 0) return;
  const int fd = std::exchange(mFd, -1);
  if (::fsync(fd) != 0) {
    const int saved = errno;
    ::close(fd);
    errno = saved;
    throw MeshError(errnoText("fsync of " + mPath.string() + " failed"));
  }
  if (::close(fd) != 0) throw MeshError(errnoText("close of " + mPath.string() + " failed"));
}

MeshInputFile::MeshInputFile(const std::filesystem::path& path) : mPath(path) {
  mFd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (mFd < 0) throw MeshError(errnoText("cannot open " + path.string()));
  struct stat st {};
  if (::fstat(mFd, &st) != 0) {
    const int saved = errno;
    ::close(mFd);
    mFd = -1;
    errno = saved;
    throw MeshError(errnoText("cannot stat " + path.string()));
  }
  mSize = static_cast<uint64_t>(st.st_size);
}

MeshInputFile::~MeshInputFile() {
  if (mFd >= 0) ::close(mFd);
}

MeshInputFile::MeshInputFile(MeshInputFile&& other) noexcept
    : mPath(std::move(other.mPath)), mFd(std::exchange(other.mFd, -1)), mSize(other.mSize) {}

MeshInputFile& MeshInputFile::operator=(MeshInputFile&& other) noexcept {
  if (this != &other) {
    if (mFd >= 0) ::close(mFd);
    mPath = std::move(other.mPath);
    mFd = std::exchange(other.mFd, -1);
    mSize = other.mSize;
  }
  return *this;
}

void MeshInputFile::readAt(uint64_t offset, void* dst, size_t size) const {
  char* p = static_cast<char*>(dst);
  while (size > 0) {
    const ssize_t n = ::pread(mFd, p, size, static_cast<off_t>(offset));
    if (n < 0) {
      if (errno == EINTR) continue;
      throw MeshError(errnoText("read of " + mPath.string() + " failed"));
    }
    if (n == 0) throw MeshError(mPath.string() + ": unexpected end of file at byte " + std::to_string(offset));
    p += n;
    offset += static_cast<uint64_t>(n);
    size -= static_cast<size_t>(n);
  }
}

void MeshInputFile::readBlock(const BlockRef& ref, void* dst, uint64_t rawSize, const std::string& what) const {
  // checkBlockRef ran at open; these guard a BlockRef that did not come from a checked index.
  checkBlockRef(ref, mSize, rawSize, mPath.string(), what);
  std::vector<char> compressed(ref.compressedSize);
  readAt(ref.offset, compressed.data(), compressed.size());
  if (common::crc32Of(compressed.data(), compressed.size()) != ref.crc32)
    throw MeshError(mPath.string() + ": " + what + ": checksum mismatch (corrupt data)");
  const unsigned long long declared = ZSTD_getFrameContentSize(compressed.data(), compressed.size());
  if (declared != rawSize)
    throw MeshError(mPath.string() + ": " + what + ": not a zstd frame of " + std::to_string(rawSize) + " bytes");
  std::vector<char> planes(rawSize);
  const size_t n = ZSTD_decompress(planes.data(), planes.size(), compressed.data(), compressed.size());
  if (ZSTD_isError(n) || n != rawSize) {
    const std::string fault = ZSTD_isError(n) ? ZSTD_getErrorName(n) : "decodes to " + std::to_string(n) + " bytes";
    throw MeshError(mPath.string() + ": " + what + ": " + fault);
  }
  unshuffle4(planes.data(), static_cast<char*>(dst), rawSize / 4);
}

void checkBlockRef(const BlockRef& ref, uint64_t dataFileSize, uint64_t expectedRawSize, const std::string& where,
                   const std::string& what) {
  const std::string prefix = where + ": " + what;
  if (ref.reserved != 0) throw MeshError(prefix + ": reserved field is not zero");
  if (ref.rawSize != expectedRawSize)
    throw MeshError(prefix + ": " + std::to_string(ref.rawSize) + " bytes decoded, the counts give " +
                    std::to_string(expectedRawSize));
  if (ref.offset > dataFileSize || ref.compressedSize > dataFileSize - ref.offset)
    throw MeshError(prefix + ": block [" + std::to_string(ref.offset) + ", +" + std::to_string(ref.compressedSize) +
                    ") lies past the end of the data (" + std::to_string(dataFileSize) + " bytes)");
  if (ref.compressedSize == 0 || ref.rawSize / kMaxZstdRatio > ref.compressedSize)
    throw MeshError(prefix + ": " + std::to_string(ref.compressedSize) + " compressed bytes cannot decode to " +
                    std::to_string(ref.rawSize));
}

}  // namespace voxbrick::mesh
