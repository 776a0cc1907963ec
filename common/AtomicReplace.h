// Replacing a file or a directory in one step: the new one is written under a fresh name beside its final place,
// flushed to the disk, and only then put at the path, so that a reader (or a crash) finds the old one whole or the
// new one whole, and a failed write leaves the old one untouched and nothing beside it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <stdexcept>

namespace voxbrick::common {

/// A replacement that failed in its own steps (creating the temporary, flushing it, renaming it); the message names
/// the path being replaced and the reason. The callers' writers throw their own errors, which pass through.
class ReplaceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Writes the file at `path` through `write`, which is given a fresh, empty file beside `path` (".NAME.tmp-...", in
/// the same directory) and fills it by its path. Then the file is flushed (fsync), renamed over `path` (rename(2):
/// at every moment the path holds the old file or the new one) and the directory flushed. If `write` throws or a
/// step fails, the temporary is removed and `path` is as it was; a trailing slash on `path` is ignored.
void replaceFile(const std::filesystem::path& path,
                 const std::function<void(const std::filesystem::path& temporary)>& write);
/// replaceFile with `bytes` as the whole content.
void replaceFile(const std::filesystem::path& path, std::span<const uint8_t> bytes);

/// How replaceDirectory puts its directory at a path that holds something already.
enum class DirectorySwap {
  /// Exchanged in one step (renameat2 RENAME_EXCHANGE): at no moment, even across a crash, is there neither the old
  /// nor the new at the path. Where the file system cannot exchange (EINVAL, ENOSYS, ENOTSUP), MoveAside instead.
  Exchange,
  /// The old one renamed to ".NAME.old-..." beside it, the new one renamed in, the old one put back if that fails.
  /// Between the two renames (microseconds) there is nothing at the path; a crash there leaves the old one whole
  /// under its ".old-" name.
  MoveAside,
};

/// Writes the directory at `path` through `write`, which is given a fresh, empty directory beside `path`
/// (".NAME.tmp-...") to fill. Then every file and directory in it is flushed (fsync), it is put at `path` (renamed
/// there if nothing is there, else swapped in as `swap` says), the parent directory is flushed and the old one
/// removed. If `write` throws or a step fails, the temporary is removed and `path` is as it was; a trailing slash on
/// `path` is ignored.
void replaceDirectory(const std::filesystem::path& path,
                      const std::function<void(const std::filesystem::path& staging)>& write,
                      DirectorySwap swap = DirectorySwap::Exchange);

}  // namespace voxbrick::common
