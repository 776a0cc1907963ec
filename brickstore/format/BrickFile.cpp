// bricks.bin I/O. Writes go straight to the descriptor so that ENOSPC/EFBIG surface at the brick that hit them.
#include "brickstore/format/BrickFile.h"

#include <fcntl.h>
#include <unistd.h>

#include <sys/stat.h>
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "brickstore/format/Codec.h"
#include "brickstore/format/Errors.h"

namespace voxbrick::store {

OutputFile::OutputFile(const std::filesystem::path& path) : mPath(path) {
  mFd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (mFd < 0) throw IoError(errnoMessage("cannot create " + path.string()));
}

OutputFile::~OutputFile() {
  if (mFd >= 0) ::close(mFd);
}

uint64_t OutputFile::append(const void* data, size_t size) {
  uint64_t start = mSize;
  const char* p = static_cast<const char*>(data);
  size_t left = size;
  while (left > 0) {
    ssize_t n = ::write(mFd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw IoError(errnoMessage("write to " + mPath.string() + " failed"));
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  mSize += size;
  return start;
}

void OutputFile::close() {
  if (mFd < 0) return;
  int fd = mFd;
  mFd = -1;
  if (::fsync(fd) != 0) {
    int saved = errno;
    ::close(fd);
    errno = saved;
    throw IoError(errnoMessage("fsync of " + mPath.string() + " failed"));
  }
  if (::close(fd) != 0) throw IoError(errnoMessage("close of " + mPath.string() + " failed"));
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
