// A tetrahedral mesh as a dataset: its source of tets and the metadata a client is given. GL-free.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "render/core/Dataset.h"
#include "render/tets/TetMeshSource.h"

namespace voxbrick::render {

/// A mesh dataset: what the server and `render` open; RenderEngine draws it with a TetRenderer.
class TetMeshDataset final : public Dataset {
 public:
  /// A dataset of `source` under `name`, read from `path`.
  TetMeshDataset(std::string name, const std::filesystem::path& path, std::shared_ptr<const TetMeshSource> source);

  static constexpr std::string_view kKind = "tet-mesh";
  std::string_view kind() const override { return kKind; }
  /// {"kind": "tet-mesh", "tets", "points", "field", "bounds", "value_range", "reference_length", "paged",
  /// "chunks"}.
  std::string infoJson() const override;
  /// A paged mesh's working sets (TetMeshSource::cacheStats); zero for a mesh held whole.
  store::CacheStats cacheStats() const override { return mSource->cacheStats(); }
  void setCacheBudget(size_t bytes) const override { mSource->setBudget(bytes); }

  const std::shared_ptr<const TetMeshSource>& source() const { return mSource; }

 private:
  std::shared_ptr<const TetMeshSource> mSource;
};

}  // namespace voxbrick::render
