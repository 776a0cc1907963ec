// What the server opens and a renderer draws: a dataset. Two kinds: a brick store with its host cache, backed by a
// prepped store directory or by an OpenVDB file read live (both give the same bricks, so one renderer draws them),
// and a tetrahedral mesh (render/TetDataset.h), with its own renderer behind RenderEngine. GL-free.
#pragma once

#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "brickstore/BrickCache.h"
#include "brickstore/BrickStore.h"
#include "render/Quality.h"
#include "render/Scene.h"
#include "render/WorldFrame.h"

namespace voxbrick::render {

/// The kinds of dataset; RenderEngine picks the renderer by kind.
enum class DatasetKind { BrickStore, TetMesh };

/// "brick-store", "tet-mesh".
const char* datasetKindName(DatasetKind kind);

/// An opened dataset, shared (read-only) by every session and render thread.
class Dataset {
 public:
  virtual ~Dataset() = default;
  Dataset(const Dataset&) = delete;
  Dataset& operator=(const Dataset&) = delete;

  virtual DatasetKind kind() const = 0;
  /// Its name (in the server: the directory name under the datasets directory).
  const std::string& name() const { return mName; }
  const std::filesystem::path& path() const { return mPath; }
  /// The metadata a client is given when it opens the dataset (JSON text).
  virtual std::string infoJson() const = 0;
  /// Where the renderer's local frame lies in the world (the identity for meshes, whose points are in the world).
  virtual WorldFrame worldFrame() const { return {}; }
  /// The host cache's counters, for statistics.
  virtual store::CacheStats cacheStats() const = 0;
  /// Changes the host cache's budget (the cache is shared and thread-safe, so this is allowed on a const dataset).
  virtual void setCacheBudget(size_t bytes) const = 0;

  /// Marks the dataset as failing its checks (e.g. a corrupt brick met while drawing): a server then answers its
  /// renders with `reason` without drawing, until the data is replaced on disk and opened again. The first reason
  /// stays. Thread-safe, so allowed on a const dataset.
  void quarantine(const std::string& reason) const {
    std::lock_guard lock(mQuarantineMutex);
    if (!mQuarantine) mQuarantine = reason;
  }
  /// Why the dataset is quarantined; nothing if it is not.
  std::optional<std::string> quarantined() const {
    std::lock_guard lock(mQuarantineMutex);
    return mQuarantine;
  }

 /// The dataset's quality table (QualityTable::load: DIR/quality.json, FILE.quality.json), read on first use and
  /// again whenever the file changes (so a calibration made while a server runs takes effect); none if there is
  /// none. Throws RenderInputError for a malformed one. Thread-safe.
  std::optional<QualityTable> qualityTable() const;

 protected:
  Dataset(std::string name, std::filesystem::path path) : mName(std::move(name)), mPath(std::move(path)) {}

 private:
  std::string mName;
  std::filesystem::path mPath;
  mutable std::mutex mQualityMutex;
  mutable std::optional<QualityTable> mQuality;
  mutable std::filesystem::file_time_type mQualityTime{};
  mutable std::mutex mQuarantineMutex;
  mutable std::optional<std::string> mQuarantine;
};

/// A brick store (a prepped directory, or a .vdb read live) and its bounded host cache.
class BrickStoreDataset final : public Dataset {
 public:
  /// Opens the store at `path` (store::BrickStore::openAny: a .vdb file is read live with `options`) with a host
  /// cache of `cacheBytes` and `decodeThreads` prefetch workers; throws the store's errors (InputError,
  /// CorruptStoreError, IoError) naming the problem.
  BrickStoreDataset(std::string name, const std::filesystem::path& path, size_t cacheBytes, int decodeThreads = 2,
                    const store::StoreOpenOptions& options = {});

  DatasetKind kind() const override { return DatasetKind::BrickStore; }
  /// The store's metadata with "kind" and "orientation" (always present; the identity when the input had none).
  std::string infoJson() const override;
  /// The store's orientation placed around its local box.
  WorldFrame worldFrame() const override;
  store::CacheStats cacheStats() const override { return mCache->stats(); }
  void setCacheBudget(size_t bytes) const override { mCache->setBudget(bytes); }

  const std::shared_ptr<const store::BrickStore>& store() const { return mStore; }
  const std::shared_ptr<store::BrickCache>& cache() const { return mCache; }

 private:
  std::shared_ptr<const store::BrickStore> mStore;
  std::shared_ptr<store::BrickCache> mCache;
};

/// `scene` with its quality target (Scene::quality) resolved through the dataset's quality table: the drawing
/// settings replaced by the chosen ones, and `choice` (if given) set to what was chosen. A scene without a target
/// comes back as it is. Throws RenderInputError when the dataset has no table, saying how to make one.
Scene resolveQuality(const Dataset& dataset, const Scene& scene, std::optional<QualityChoice>* choice = nullptr);

/// Whether `path` holds a dataset of a kind this build can open: a directory with a store.json, a file whose name
/// ends in .vdb (read live), or a mesh store (mesh/MeshStore.h).
bool isDataset(const std::filesystem::path& path);

/// The files whose change on disk means the dataset at `path` was replaced (a brick store's store.json and
/// bricks.bin, a mesh store's mesh.json, mesh-index.bin and mesh-data.bin, or the .vdb file itself).
std::vector<std::filesystem::path> datasetFiles(const std::filesystem::path& path);

/// Opens the dataset at `path` under `name` (`options` apply to a .vdb: grid name and brick size): a BrickStoreDataset
/// or, for a mesh store, a TetMeshDataset. `cacheBytes` is the host memory it may use: a brick store's cache; a mesh
/// is read whole when it fits (TetMeshData::hostBytes), and otherwise paged by view (TetMeshSource: its points
/// resident, each frame's chunks within the rest), refused with RenderLimitError when even its points exceed it. Throws std::runtime_error naming the path when it is no dataset, and the kind's own errors
/// (mesh::MeshError for a corrupt mesh store) when it cannot be opened.
std::shared_ptr<const Dataset> openDataset(std::string name, const std::filesystem::path& path, size_t cacheBytes,
                                           const store::StoreOpenOptions& options = {});

}  // namespace voxbrick::render
