// The datasets a server offers: the stores in one directory, opened on first use and shared by every session and
// render thread (one host brick cache per dataset).
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "brickstore/BrickCache.h"
#include "brickstore/BrickStore.h"
#include "render/Dataset.h"

namespace voxbrick::server {

struct Dataset {
  std::string name;
  std::filesystem::path path;
  std::shared_ptr<const store::BrickStore> store;
  std::shared_ptr<store::BrickCache> cache;
  std::shared_ptr<const render::Dataset> dataset;
};

/// A named dataset is a subdirectory of the datasets directory holding a store.json; names are the directory
/// names, of letters, digits, '.', '-' and '_' only (never a path).
class DatasetRegistry {
 public:
  DatasetRegistry(std::filesystem::path directory, size_t cacheBytesPerDataset);

  /// The datasets present now, sorted (the directory is scanned on every call, so stores added later appear).
  std::vector<std::string> names() const;
  /// Opens `name` (or returns it if already open). Throws DatasetNotFound for a name that is not a store of the
  /// directory, and the store's own errors (CorruptStoreError, IoError) for one that cannot be opened.
  std::shared_ptr<const Dataset> open(const std::string& name);
  /// The datasets opened so far.
  std::vector<std::shared_ptr<const Dataset>> opened() const;

  const std::filesystem::path& directory() const { return mDirectory; }

 private:
  std::filesystem::path mDirectory;
  size_t mCacheBytes;
  mutable std::mutex mMutex;
  std::map<std::string, std::shared_ptr<const Dataset>> mOpen;
};

class DatasetNotFound : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace voxbrick::server
