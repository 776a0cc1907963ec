// A brick store as a dataset: a prepped store directory or an OpenVDB file read live (both give the same bricks, so
// one renderer draws them), with its bounded host cache. GL-free.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"
#include "render/core/Dataset.h"
#include "render/core/WorldFrame.h"

namespace voxbrick::render {

/// A brick store (a prepped directory, or a .vdb read live) and its bounded host cache.
class BrickStoreDataset final : public Dataset {
 public:
  /// Opens the store at `path` (store::openAnyStore: a .vdb file is read live with `options`) with a host
  /// cache of `cacheBytes` and `decodeThreads` prefetch workers; throws the store's errors (InputError,
  /// CorruptStoreError, IoError) naming the problem.
  BrickStoreDataset(std::string name, const std::filesystem::path& path, size_t cacheBytes, int decodeThreads = 2,
                    const store::StoreOpenOptions& options = {});

  static constexpr std::string_view kKind = "brick-store";
  std::string_view kind() const override { return kKind; }
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

}  // namespace voxbrick::render
