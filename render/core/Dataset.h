// What the server opens and a renderer draws: a dataset. The base of every kind (render/volume/BrickStoreDataset.h: a
// brick store with its host cache; render/tets/TetMeshDataset.h: a tetrahedral mesh), its quality table and its
// quarantine. Whatever depends on a dataset's kind (opening one by path, its renderer, its reference, ...) is its
// kind's driver (render/engine/DatasetDriver.h). GL-free.
#pragma once

#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "brickstore/read/BrickCache.h"
#include "render/core/Quality.h"
#include "render/core/Scene.h"
#include "render/core/WorldFrame.h"

namespace voxbrick::render {

/// An opened dataset, shared (read-only) by every session and render thread.
class Dataset {
 public:
  virtual ~Dataset() = default;
  Dataset(const Dataset&) = delete;
  Dataset& operator=(const Dataset&) = delete;

  /// Its kind's name ("brick-store", "tet-mesh", ...): what RenderEngine finds the kind's driver by
  /// (render/engine/DatasetDriver.h), and what a client is told. Nothing else decides by it.
  virtual std::string_view kind() const = 0;
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

/// `scene` with its quality target (Scene::quality) resolved through the dataset's quality table: the drawing
/// settings replaced by the chosen ones, and `choice` (if given) set to what was chosen. A scene without a target
/// comes back as it is. Throws RenderInputError when the dataset has no table, saying how to make one.
Scene resolveQuality(const Dataset& dataset, const Scene& scene, std::optional<QualityChoice>* choice = nullptr);

}  // namespace voxbrick::render
