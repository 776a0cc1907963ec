// Blocks and files of the mesh store. Reads are pread so that chunks can be paged from several threads.
#include "mesh/MeshBlocks.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "common/BlockCodec.h"
#include "common/Checksum.h"
#include "mesh/TetMesh.h"

namespace voxbrick::mesh {
namespace {

std::string errnoText(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace

std::vector<char> encodeBlock(const void* values, size_t bytes, int level) {
  if (bytes % 4 != 0)
    throw MeshError("encodeBlock: " + std::to_string(bytes) + " bytes is not a whole number of values");
  std::vector<char> out;
  try {
    common::encodeBlock(values, bytes, {4, level, false, false}, out);
  } catch (const common::CodecError& e) {
    throw MeshError(std::string("encodeBlock: zstd failed: ") + e.what());
  }
  return out;
}

void throwMeshError(const std::string& message) { throw MeshError(message); }

BlockRef appendBlock(common::OutputFile& file, const std::vector<char>& encoded, uint64_t rawSize) {
  BlockRef ref{};
  ref.compressedSize = encoded.size();
  ref.rawSize = rawSize;
  ref.crc32 = common::crc32Of(encoded.data(), encoded.size());
  ref.offset = file.append(encoded.data(), encoded.size());
  return ref;
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
  const common::BlockDecoding d = common::decodeBlock(compressed.data(), compressed.size(), 4, dst, rawSize, true);
  switch (d.fault) {
    case common::BlockFault::None: return;
    case common::BlockFault::NotAFrame:
    case common::BlockFault::SizeUnknown:
    case common::BlockFault::SizeDiffers:
      throw MeshError(mPath.string() + ": " + what + ": not a zstd frame of " + std::to_string(rawSize) + " bytes");
    case common::BlockFault::Corrupt: throw MeshError(mPath.string() + ": " + what + ": " + d.zstdError);
    case common::BlockFault::WrongLength:
      throw MeshError(mPath.string() + ": " + what + ": decodes to " + std::to_string(d.size) + " bytes");
  }
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
