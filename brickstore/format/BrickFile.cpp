// bricks.bin's frames and their reading.
#include "brickstore/format/BrickFile.h"

#include <fcntl.h>
#include <unistd.h>

#include <sys/stat.h>
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "brickstore/format/Errors.h"
#include "common/BlockCodec.h"

namespace voxbrick::store {

void compressFrame(const void* src, size_t size, size_t elementSize, int level, std::vector<char>& dst) {
  try {
    common::encodeBlock(src, size, {elementSize, level, true, level == 1 && elementSize == 4}, dst);
  } catch (const common::CodecError& e) {
    throw StoreError(std::string("compressFrame: zstd: ") + e.what());
  }
}

void decompressFrame(const void* src, size_t size, size_t elementSize, void* dst, size_t expectedSize,
                     const std::string& what) {
  const common::BlockDecoding d = common::decodeBlock(src, size, elementSize, dst, expectedSize, false);
  switch (d.fault) {
    case common::BlockFault::None:
    case common::BlockFault::SizeUnknown: return;
    case common::BlockFault::NotAFrame: throw CorruptStoreError(what + ": not a zstd frame");
    case common::BlockFault::SizeDiffers:
      throw CorruptStoreError(what + ": frame holds " + std::to_string(d.size) + " bytes, expected " +
                              std::to_string(expectedSize));
    case common::BlockFault::Corrupt: throw CorruptStoreError(what + ": corrupt zstd frame (" + d.zstdError + ")");
    case common::BlockFault::WrongLength:
      throw CorruptStoreError(what + ": decoded " + std::to_string(d.size) + " bytes, expected " +
                              std::to_string(expectedSize));
  }
}

BrickFileReader::BrickFileReader(const std::filesystem::path& path, ValueType type)
    : mPath(path), mType(type), mElementSize(valueSize(type)) {
  mFd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (mFd < 0) throw IoError(errnoMessage("cannot open " + path.string()));
}

BrickFileReader::~BrickFileReader() {
  if (mFd >= 0) ::close(mFd);
}

BrickFileReader::BrickFileReader(BrickFileReader&& other) noexcept
    : mPath(std::move(other.mPath)),
      mType(other.mType),
      mElementSize(other.mElementSize),
      mFd(std::exchange(other.mFd, -1)) {}

BrickFileReader& BrickFileReader::operator=(BrickFileReader&& other) noexcept {
  if (this != &other) {
    if (mFd >= 0) ::close(mFd);
    mPath = std::move(other.mPath);
    mType = other.mType;
    mElementSize = other.mElementSize;
    mFd = std::exchange(other.mFd, -1);
  }
  return *this;
}

uint64_t BrickFileReader::fileSize() const {
  struct stat st {};
  if (::fstat(mFd, &st) != 0) throw IoError(errnoMessage("cannot stat " + mPath.string()));
  return static_cast<uint64_t>(st.st_size);
}

void BrickFileReader::decode(const BrickRecord& record, const BrickKey& key, void* dst, size_t bytes) const {
  // Frames are small (a few KiB to a few MiB): one buffer per thread avoids an allocation per brick.
  thread_local std::vector<char> frame;
  frame.resize(record.compressedSize);
  size_t done = 0;
  while (done < record.compressedSize) {
    ssize_t n =
        ::pread(mFd, frame.data() + done, record.compressedSize - done, static_cast<off_t>(record.offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw IoError(errnoMessage(mPath.string() + ": reading " + toString(key)));
    if (n == 0) throw CorruptStoreError(mPath.string() + ": " + toString(key) + " lies past the end of the file");
    done += static_cast<size_t>(n);
  }
  decompressFrame(frame.data(), frame.size(), mElementSize, dst, bytes, mPath.string() + ": " + toString(key));
}

void BrickFileReader::read(const BrickRecord& record, const BrickKey& key, void* dst, size_t bytes,
                           double background) const {
  if (record.compressedSize != 0)
    decode(record, key, dst, bytes);
  else
    fillValue(mType, background, dst, bytes / mElementSize);
}

void fillValue(ValueType type, double value, void* dst, size_t count) {
  switch (type) {
    case ValueType::U8: std::fill_n(static_cast<uint8_t*>(dst), count, static_cast<uint8_t>(value)); break;
    case ValueType::U16: std::fill_n(static_cast<uint16_t*>(dst), count, static_cast<uint16_t>(value)); break;
    case ValueType::I16: std::fill_n(static_cast<int16_t*>(dst), count, static_cast<int16_t>(value)); break;
    case ValueType::F32: std::fill_n(static_cast<float*>(dst), count, static_cast<float>(value)); break;
  }
}

}  // namespace voxbrick::store
