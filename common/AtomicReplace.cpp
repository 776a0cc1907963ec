// Atomic replacement of files and directories: a temporary beside the path, flushed, then rename(2) for a file and
// renameat2(RENAME_EXCHANGE) for a directory, which rename(2) cannot put over a non-empty one.
#include "common/AtomicReplace.h"

#include <fcntl.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <string>

namespace voxbrick::common {
namespace fs = std::filesystem;
namespace {

[[noreturn]] void fail(const std::string& what, int error) { throw ReplaceError(what + ": " + std::strerror(error)); }

/// `path` without a trailing slash, which would put the temporary inside it.
fs::path normalised(fs::path path) {
  if (path.filename().empty()) path = path.parent_path();
  if (path.filename().empty()) throw ReplaceError("cannot replace '" + path.string() + "': it names no file");
  return path;
}

fs::path parentOf(const fs::path& path) { return path.has_parent_path() ? path.parent_path() : fs::path("."); }

enum class Kind { File, Directory };

/// Creates a fresh file or directory named ".NAME.TAG-PID-N" beside `target`, with the usual modes (0666 or 0777
/// less the umask); N counts up past names that exist, so two writers of one target never share a temporary.
fs::path createSibling(const fs::path& target, const char* tag, Kind kind) {
  static std::atomic<unsigned> counter{0};
  const std::string stem = "." + target.filename().string() + "." + tag + "-" + std::to_string(::getpid()) + "-";
  for (;;) {
    const fs::path sibling = parentOf(target) / (stem + std::to_string(counter.fetch_add(1)));
    int made = -1;
    if (kind == Kind::Directory) {
      made = ::mkdir(sibling.c_str(), 0777);
    } else {
      made = ::open(sibling.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
      if (made >= 0) made = ::close(made);
    }
    if (made == 0) return sibling;
    if (errno != EEXIST) fail("cannot create " + sibling.string() + " to replace " + target.string(), errno);
  }
}

/// Removes a temporary (a file or a whole tree) when it goes out of scope, unless released.
class Temporary {
 public:
  explicit Temporary(fs::path path) : mPath(std::move(path)) {}
  ~Temporary() {
    std::error_code ignore;
    if (!mPath.empty()) fs::remove_all(mPath, ignore);
  }
  Temporary(const Temporary&) = delete;
  Temporary& operator=(const Temporary&) = delete;
  const fs::path& path() const { return mPath; }
  void release() { mPath.clear(); }

 private:
  fs::path mPath;
};

/// fsync of a file or a directory; 0 or the errno. A file system that cannot sync a directory (EINVAL) passes: how
/// durable its renames are is then up to it.
int sync(const fs::path& path, Kind kind) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | (kind == Kind::Directory ? O_DIRECTORY : 0));
  if (fd < 0) return errno;
  int error = ::fsync(fd) == 0 ? 0 : errno;
  if (kind == Kind::Directory && error == EINVAL) error = 0;
  ::close(fd);
  return error;
}

void syncOrFail(const fs::path& path, Kind kind, const fs::path& target) {
  if (const int error = sync(path, kind))
    fail("cannot flush " + path.string() + " to replace " + target.string(), error);
}

/// Flushes every file and directory below `dir`, then `dir` itself; symbolic links are not followed.
void syncTree(const fs::path& dir, const fs::path& target) {
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::file_type type = it->symlink_status(ec).type();
    if (type == fs::file_type::regular) syncOrFail(it->path(), Kind::File, target);
    if (type == fs::file_type::directory) syncOrFail(it->path(), Kind::Directory, target);
  }
  if (ec) fail("cannot list " + dir.string() + " to replace " + target.string(), ec.value());
  syncOrFail(dir, Kind::Directory, target);
}

void renameOrFail(const fs::path& from, const fs::path& to) {
  if (::rename(from.c_str(), to.c_str()) != 0) fail("cannot rename " + from.string() + " to " + to.string(), errno);
}

/// The fallback swap: `target` moved aside onto a fresh sibling, `staging` renamed in, the old one put back if that
/// fails; returns the old one's new name.
fs::path moveAsideAndRename(const fs::path& staging, const fs::path& target) {
  std::error_code ec;
  const bool directory = fs::is_directory(fs::symlink_status(target, ec));
  const fs::path old = createSibling(target, "old", directory ? Kind::Directory : Kind::File);
  if (::rename(target.c_str(), old.c_str()) != 0) {
    const int error = errno;
    std::error_code ignore;
    fs::remove(old, ignore);
    fail("cannot move aside " + target.string(), error);
  }
  if (::rename(staging.c_str(), target.c_str()) != 0) {
    const int error = errno;
    ::rename(old.c_str(), target.c_str());
    fail("cannot rename " + staging.string() + " to " + target.string(), error);
  }
  return old;
}

/// Puts the flushed directory `staging` at `target`; returns where the old one now is (empty if there was none).
fs::path putInPlace(const fs::path& staging, const fs::path& target, DirectorySwap swap) {
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(target, ec))) {
    renameOrFail(staging, target);
    return {};
  }
  if (swap == DirectorySwap::Exchange) {
    if (::renameat2(AT_FDCWD, staging.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) == 0) return staging;
    if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP) fail("cannot replace " + target.string(), errno);
  }
  return moveAsideAndRename(staging, target);
}

/// Writes all of `bytes` to the file at `path`, which exists: the temporary that will replace `target`, which the
/// errors name (a full disk or a file size limit is the target's problem to whoever reads the message).
void writeBytes(const fs::path& path, std::span<const uint8_t> bytes, const fs::path& target) {
  const std::string what = "cannot write " + target.string() + " (through " + path.filename().string() + ")";
  const int fd = ::open(path.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  if (fd < 0) fail(what, errno);
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = n < 0 ? errno : EIO;
      ::close(fd);
      fail(what, error);
    }
    done += size_t(n);
  }
  if (::close(fd) != 0) fail(what, errno);
}

}  // namespace

void replaceFile(const fs::path& path, const std::function<void(const fs::path& temporary)>& write) {
  const fs::path target = normalised(path);
  Temporary temporary(createSibling(target, "tmp", Kind::File));
  write(temporary.path());
  syncOrFail(temporary.path(), Kind::File, target);
  renameOrFail(temporary.path(), target);
  temporary.release();
  sync(parentOf(target), Kind::Directory);  // the rename is made; a failure to flush it cannot undo it
}

void replaceFile(const fs::path& path, std::span<const uint8_t> bytes) {
  replaceFile(path, [&](const fs::path& temporary) { writeBytes(temporary, bytes, path); });
}

void replaceDirectory(const fs::path& path, const std::function<void(const fs::path& staging)>& write,
                      DirectorySwap swap) {
  const fs::path target = normalised(path);
  Temporary staging(createSibling(target, "tmp", Kind::Directory));
  write(staging.path());
  syncTree(staging.path(), target);
  const fs::path old = putInPlace(staging.path(), target, swap);
  staging.release();
  sync(parentOf(target), Kind::Directory);  // the swap is made; a failure to flush it cannot undo it
  std::error_code ignore;
  if (!old.empty()) fs::remove_all(old, ignore);
}

}  // namespace voxbrick::common
