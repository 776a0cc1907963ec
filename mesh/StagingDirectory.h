// A directory written beside its final place and put there in one step only once complete, so that a reader never
// sees half a store and an existing store survives any failure before the last step.
#pragma once

#include <filesystem>

namespace voxbrick::mesh {

class StagingDirectory {
 public:
  /// Creates a fresh, empty sibling of `target` named ".NAME.tmp-XXXXXX"; throws MeshError if it cannot.
  explicit StagingDirectory(std::filesystem::path target);
  /// Removes the staging directory and everything in it unless commit() succeeded.
  ~StagingDirectory();
  StagingDirectory(const StagingDirectory&) = delete;
  StagingDirectory& operator=(const StagingDirectory&) = delete;

  /// Where to write the files (each must be fsynced by its writer).
  const std::filesystem::path& path() const { return mStaging; }
  const std::filesystem::path& target() const { return mTarget; }

  /// Syncs the staging directory, then puts it at `target`: an existing directory there is swapped out atomically
  /// (renameat2 RENAME_EXCHANGE; where the file system lacks it, moved aside and put back if the rename fails) and
  /// removed afterwards. Throws MeshError; after a failure `target` is as it was.
  void commit();

 private:
  std::filesystem::path mTarget;
  std::filesystem::path mStaging;
};

}  // namespace voxbrick::mesh
