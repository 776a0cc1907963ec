// Appending to a file, every failed write reported with the file's name and the system's reason.
#include "common/OutputFile.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace voxbrick::common {

OutputFile::OutputFile(const std::filesystem::path& path, Fail fail) : mPath(path), mFail(fail) {
  mFd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (mFd < 0) report("cannot create " + path.string());
}

OutputFile::~OutputFile() {
  if (mFd >= 0) ::close(mFd);
}

void OutputFile::report(const std::string& what) const {
  const std::string message = what + ": " + std::strerror(errno);
  mFail(message);
  throw std::runtime_error(message);  // a Fail that returned
}

uint64_t OutputFile::append(const void* data, size_t size) {
  const uint64_t start = mSize;
  const char* p = static_cast<const char*>(data);
  size_t left = size;
  while (left > 0) {
    const ssize_t n = ::write(mFd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      report("write to " + mPath.string() + " failed");
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  mSize += size;
  return start;
}

void OutputFile::close() {
  if (mFd < 0) return;
  const int fd = std::exchange(mFd, -1);
  if (::fsync(fd) != 0) {
    const int saved = errno;
    ::close(fd);
    errno = saved;
    report("fsync of " + mPath.string() + " failed");
  }
  if (::close(fd) != 0) report("close of " + mPath.string() + " failed");
}

}  // namespace voxbrick::common
