// The datasets a server offers: the datasets in one directory, opened on first use and shared by every session and
// render thread (one host brick cache per dataset, all within one budget).
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "render/core/Dataset.h"

namespace voxbrick::server {

class PacsCatalog;

/// A named dataset is an entry of the datasets directory that render::isDataset accepts: a subdirectory holding a
/// prepped store, or a .vdb file read live with the defaults (its first float grid, bricks of 32). Names are the
/// entries' names (a .vdb keeps its extension), of letters, digits, '.', '-' and '_' only, not starting with '.'
/// (never a path, never a hidden entry such as an upload's scratch folder).
class DatasetRegistry {
 public:
  /// `cacheBytes` is the host budget of all the datasets open together: each of the n open has a cache of
  /// cacheBytes / n (a dataset opened shrinks the others'). `check`, if set, is called with the name of each dataset
  /// opened (or reopened) before it is kept; what it throws is rethrown as DatasetUnavailable and nothing is kept.
  DatasetRegistry(std::filesystem::path directory, size_t cacheBytes,
                  std::function<void(const std::string&)> check = {});

  /// Which names a session may see (its access token's datasets); empty: every one.
  using Visible = std::function<bool(const std::string&)>;

  /// The datasets present now that `visible` lets through, sorted (the directory is scanned on every call, so
  /// datasets added later appear).
  std::vector<std::string> names(const Visible& visible = {}) const;
  /// Opens `name`, or returns it if already open and its files on disk are the ones it was opened from (their
  /// identity: device, inode, size and modification time); a dataset replaced on disk (e.g. by `prep --force`) is
  /// opened again, and the new one is not quarantined. Throws DatasetNotFound for a name that is not a dataset of
  /// the directory, or one `visible` does not let through, with the same text for both (the names it suggests are
  /// visible ones): a session learns nothing of datasets it may not see. Throws the dataset's own errors
  /// (CorruptStoreError, IoError) for one that cannot be opened.
  std::shared_ptr<const render::Dataset> open(const std::string& name, const Visible& visible = {});
  /// Serves the series of `pacs` beside the directory's datasets (names "ID.SERIESUID": PacsCatalog), from its
  /// cache; opening one not cached yet throws its Busy. Before any session; null: none.
  void attach(PacsCatalog* pacs) { mPacs = pacs; }
  /// The datasets opened so far, by name.
  std::vector<std::shared_ptr<const render::Dataset>> opened() const;

  const std::filesystem::path& directory() const { return mDirectory; }

  /// Whether `name` may name a dataset at all (see the class comment); says nothing of whether it exists.
  static bool validName(const std::string& name);

 private:
  std::filesystem::path mDirectory;
  size_t mCacheBytes;
  std::function<void(const std::string&)> mCheck;
  mutable std::mutex mMutex;
  struct Open {
    std::shared_ptr<const render::Dataset> dataset;
    std::string identity;  // of its files when opened (datasetIdentity)
  };
  std::map<std::string, Open> mOpen;
  PacsCatalog* mPacs = nullptr;
};

/// The identity of a dataset's files (render::datasetFiles: a brick store's store.json and bricks.bin, a mesh
/// store's three files, or a .vdb file): device, inode, size and modification time of each, as text; empty when they
/// cannot be read.
std::string datasetIdentity(const std::filesystem::path& path);

/// A Render for a quarantined dataset (answered as Internal, without drawing and without logging again).
class DatasetUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// OpenDataset named no dataset of the directory (the client's mistake): UnknownDataset.
class DatasetNotFound : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace voxbrick::server
