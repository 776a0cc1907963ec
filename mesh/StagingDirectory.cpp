// Atomic directory replacement, the mesh store's own (mesh/ may not link the brick store, which does the same).
#include "mesh/StagingDirectory.h"

#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <vector>

#include "mesh/TetMesh.h"

namespace voxbrick::mesh {
namespace fs = std::filesystem;
namespace {

fs::path parentOf(const fs::path& p) { return p.has_parent_path() ? p.parent_path() : fs::path("."); }

/// mkdtemp on "<parent>/.<name>.<tag>-XXXXXX": unique even for two writers of the same target in one process.
fs::path makeSibling(const fs::path& target, const std::string& tag) {
  const std::string pattern = (parentOf(target) / ("." + target.filename().string() + "." + tag + "-XXXXXX")).string();
  std::vector<char> buffer(pattern.begin(), pattern.end());
  buffer.push_back('\0');
  if (::mkdtemp(buffer.data()) == nullptr)
    throw MeshError("cannot create a directory beside " + target.string() + ": " + std::strerror(errno));
  return fs::path(buffer.data());
}

void syncDirectory(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

StagingDirectory::StagingDirectory(fs::path target) : mTarget(std::move(target)) {
  // A trailing slash would make the sibling a child of the target.
  if (mTarget.filename().empty()) mTarget = mTarget.parent_path();
  if (mTarget.empty()) throw MeshError("StagingDirectory: empty target path");
  mStaging = makeSibling(mTarget, "tmp");
}

StagingDirectory::~StagingDirectory() {
  std::error_code ec;
  if (!mStaging.empty()) fs::remove_all(mStaging, ec);
}

void StagingDirectory::commit() {
  syncDirectory(mStaging);
  const fs::path parent = parentOf(mTarget);
  std::error_code ec;
  if (!fs::exists(mTarget, ec)) {
    fs::rename(mStaging, mTarget, ec);
    if (ec) throw MeshError("cannot rename " + mStaging.string() + " to " + mTarget.string() + ": " + ec.message());
    mStaging.clear();
    syncDirectory(parent);
    return;
  }
  // An exchange leaves no moment without a store at the target, even across a crash.
  if (::renameat2(AT_FDCWD, mStaging.c_str(), AT_FDCWD, mTarget.c_str(), RENAME_EXCHANGE) == 0) {
    syncDirectory(parent);
    fs::remove_all(mStaging, ec);  // now the old store
    mStaging.clear();
    return;
  }
  if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP)
    throw MeshError("cannot replace " + mTarget.string() + ": " + std::strerror(errno));
  // No exchange on this file system: move the old store aside, rename, and put it back if that fails.
  const fs::path old = makeSibling(mTarget, "old");
  fs::rename(mTarget, old, ec);  // onto the empty directory mkdtemp made
  if (ec) {
    std::error_code ignore;
    fs::remove(old, ignore);
    throw MeshError("cannot move aside " + mTarget.string() + ": " + ec.message());
  }
  fs::rename(mStaging, mTarget, ec);
  if (ec) {
    std::error_code ignore;
    fs::rename(old, mTarget, ignore);
    throw MeshError("cannot rename " + mStaging.string() + " to " + mTarget.string() + ": " + ec.message());
  }
  mStaging.clear();
  syncDirectory(parent);
  fs::remove_all(old, ec);
}

}  // namespace voxbrick::mesh
