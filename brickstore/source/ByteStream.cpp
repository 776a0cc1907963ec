// Plain and gzip sequential file reading for the ingest sources (zlib inflate over pread chunks).
#include "brickstore/source/ByteStream.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>
#include <new>
#include <utility>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

constexpr size_t kInputChunk = size_t(1) << 18;

// Opens read-only or throws IoError; the caller owns the descriptor.
int openForReading(const std::string& path) {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw IoError(errnoMessage(path));
  return fd;
}

// pread that retries interrupted calls and throws IoError on real failures; 0 means end of file.
size_t preadSome(int fd, void* dst, size_t n, int64_t offset, const std::string& path) {
  for (;;) {
    ssize_t got = ::pread(fd, dst, n, static_cast<off_t>(offset));
    if (got >= 0) return static_cast<size_t>(got);
    if (errno != EINTR) throw IoError(errnoMessage(path));
  }
}

class FdCloser {
 public:
  explicit FdCloser(int fd) : mFd(fd) {}
  ~FdCloser() { ::close(mFd); }
  FdCloser(const FdCloser&) = delete;
  FdCloser& operator=(const FdCloser&) = delete;

 private:
  int mFd;
};

}  // namespace

struct ByteStream::Inflater {
  z_stream zs{};
  std::vector<unsigned char> input;
  bool eof = false;          // the file has no more bytes
  bool memberEnded = false;  // a gzip member finished; another may follow (concatenated gzip)
};

ByteStream::ByteStream(const std::string& path, int64_t offset, Compression compression)
    : mPath(path), mFileOffset(offset), mCompression(compression) {
  if (offset < 0) throw InputError(path + ": negative data offset " + std::to_string(offset));
  if (compression == Compression::Gzip) {
    auto inflater = std::make_unique<Inflater>();
    inflater->input.resize(kInputChunk);
    // 15 + 32: maximum window, and accept either a gzip or a zlib header.
    int rc = inflateInit2(&inflater->zs, 15 + 32);
    if (rc == Z_MEM_ERROR) throw std::bad_alloc();
    if (rc != Z_OK) throw IoError(path + ": cannot initialise zlib (code " + std::to_string(rc) + ")");
    mInflater = std::move(inflater);
  }
  try {
    mFd = openForReading(path);
  } catch (...) {
    if (mInflater) inflateEnd(&mInflater->zs);
    throw;
  }
}

ByteStream::~ByteStream() {
  if (mInflater) inflateEnd(&mInflater->zs);
  if (mFd >= 0) ::close(mFd);
}

void ByteStream::throwTruncated(size_t expected, size_t got, const char* what) const {
  throw InputError(mPath + ": truncated: expected " + std::to_string(expected) + " more bytes of " + what + ", got " +
                   std::to_string(got));
}

void ByteStream::readExact(void* dst, size_t n) {
  size_t got = readUpTo(dst, n);
  if (got < n) throwTruncated(n, got, "voxel data");
}

size_t ByteStream::readUpTo(void* dst, size_t n) {
  size_t got = mCompression == Compression::Gzip ? readGzip(dst, n) : readPlain(dst, n);
  mPosition += got;
  return got;
}

void ByteStream::skip(uint64_t n) {
  if (mCompression == Compression::None) {
    // A skip past the end shows up as truncation on the next read.
    mFileOffset += static_cast<int64_t>(n);
    mPosition += n;
    return;
  }
  std::vector<char> scratch(static_cast<size_t>(std::min<uint64_t>(n, kInputChunk)));
  uint64_t done = 0;
  while (done < n) {
    size_t want = static_cast<size_t>(std::min<uint64_t>(n - done, scratch.size()));
    size_t got = readUpTo(scratch.data(), want);
    done += got;
    if (got < want) throwTruncated(static_cast<size_t>(n), static_cast<size_t>(done), "data before the voxels");
  }
}

void ByteStream::verifyEnd() {
  if (!mInflater) return;
  Inflater& inf = *mInflater;
  std::vector<unsigned char> scratch;
  while (!inf.memberEnded) {
    if (inf.zs.avail_in == 0 && !inf.eof) fillInput();
    if (scratch.empty()) scratch.resize(kInputChunk);
    inf.zs.next_out = scratch.data();
    inf.zs.avail_out = static_cast<uInt>(scratch.size());
    int rc = inflate(&inf.zs, Z_NO_FLUSH);
    if (rc == Z_STREAM_END) {
      inf.memberEnded = true;
    } else if (rc == Z_BUF_ERROR && inf.eof && inf.zs.avail_in == 0) {
      throw InputError(mPath + ": truncated: gzip data ends before its end-of-stream checksum");
    } else if (rc == Z_MEM_ERROR) {
      throw std::bad_alloc();
    } else if (rc != Z_OK && rc != Z_BUF_ERROR) {
      throwCorrupt(rc);
    }
  }
}

void ByteStream::throwCorrupt(int zlibCode) const {
  const char* msg = mInflater->zs.msg;
  throw InputError(mPath + ": corrupt gzip data (" + (msg ? msg : "zlib code " + std::to_string(zlibCode)) + ")");
}

size_t ByteStream::readPlain(void* dst, size_t n) {
  auto* out = static_cast<char*>(dst);
  size_t done = 0;
  while (done < n) {
    size_t got = preadSome(mFd, out + done, std::min<size_t>(n - done, size_t(1) << 30), mFileOffset, mPath);
    if (got == 0) break;
    done += got;
    mFileOffset += static_cast<int64_t>(got);
  }
  return done;
}

void ByteStream::fillInput() {
  Inflater& inf = *mInflater;
  size_t got = preadSome(mFd, inf.input.data(), inf.input.size(), mFileOffset, mPath);
  mFileOffset += static_cast<int64_t>(got);
  if (got == 0) inf.eof = true;
  inf.zs.next_in = inf.input.data();
  inf.zs.avail_in = static_cast<uInt>(got);
}

size_t ByteStream::readGzip(void* dst, size_t n) {
  Inflater& inf = *mInflater;
  z_stream& zs = inf.zs;
  auto* out = static_cast<unsigned char*>(dst);
  size_t done = 0;
  while (done < n) {
    if (zs.avail_in == 0 && !inf.eof) fillInput();
    if (inf.memberEnded) {
      if (zs.avail_in == 0) break;  // the data ends cleanly after a complete member
      inflateReset(&zs);
      inf.memberEnded = false;
    }
    size_t want = std::min<size_t>(n - done, UINT_MAX);
    zs.next_out = out + done;
    zs.avail_out = static_cast<uInt>(want);
    int rc = inflate(&zs, Z_NO_FLUSH);
    done += want - zs.avail_out;
    if (rc == Z_STREAM_END) {
      inf.memberEnded = true;
    } else if (rc == Z_BUF_ERROR) {
      // No progress possible: only an end of input inside a member gets here, since input is refilled above.
      if (inf.eof && zs.avail_in == 0) break;
    } else if (rc == Z_MEM_ERROR) {
      throw std::bad_alloc();
    } else if (rc != Z_OK) {
      throwCorrupt(rc);
    }
  }
  return done;
}

int64_t fileSize(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw IoError(errnoMessage(path));
  return static_cast<int64_t>(st.st_size);
}

bool isGzipFile(const std::string& path) {
  int fd = openForReading(path);
  FdCloser closer(fd);
  unsigned char magic[2] = {0, 0};
  size_t got = 0;
  while (got < 2) {
    size_t more = preadSome(fd, magic + got, 2 - got, static_cast<int64_t>(got), path);
    if (more == 0) break;
    got += more;
  }
  return got == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
}

std::vector<char> readFilePrefix(const std::string& path, size_t maxBytes) {
  auto compression = isGzipFile(path) ? ByteStream::Compression::Gzip : ByteStream::Compression::None;
  ByteStream stream(path, 0, compression);
  std::vector<char> bytes(maxBytes);
  bytes.resize(stream.readUpTo(bytes.data(), maxBytes));
  return bytes;
}

int64_t offsetAfterLines(const std::string& path, int64_t offset, int64_t lines) {
  if (lines <= 0) return offset;
  ByteStream stream(path, offset, ByteStream::Compression::None);
  std::vector<char> chunk(kInputChunk);
  int64_t seen = 0;
  int64_t position = offset;
  for (;;) {
    size_t got = stream.readUpTo(chunk.data(), chunk.size());
    if (got == 0) {
      throw InputError(path + ": truncated: file ends after " + std::to_string(seen) + " of the " +
                       std::to_string(lines) + " lines to skip");
    }
    for (size_t i = 0; i < got; ++i) {
      if (chunk[i] == '\n' && ++seen == lines) return position + static_cast<int64_t>(i) + 1;
    }
    position += static_cast<int64_t>(got);
  }
}

std::unique_ptr<ByteStream> openVoxelData(const std::string& path, int64_t start, int64_t skip, bool gzip,
                                          int64_t dataBytes) {
  if (gzip) {
    auto stream = std::make_unique<ByteStream>(path, start, ByteStream::Compression::Gzip);
    stream->skip(static_cast<uint64_t>(skip));
    return stream;
  }
  // Raw data can be checked against the file size before any voxel is read.
  const int64_t size = fileSize(path);
  const int64_t offset = skip == -1 ? size - dataBytes : start + skip;
  if (offset < start || size - offset < dataBytes) {
    throw InputError(path + ": truncated: expected " + std::to_string(dataBytes) + " bytes of voxel data from byte " +
                     std::to_string(std::max(offset, start)) + ", file has " + std::to_string(size) + " bytes");
  }
  return std::make_unique<ByteStream>(path, offset, ByteStream::Compression::None);
}

}  // namespace voxbrick::store
