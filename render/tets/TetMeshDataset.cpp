// A mesh dataset and its metadata.
#include "render/tets/TetMeshDataset.h"

#include <nlohmann/json.hpp>

namespace voxbrick::render {

TetMeshDataset::TetMeshDataset(std::string name, const std::filesystem::path& path,
                               std::shared_ptr<const TetMeshSource> source)
    : Dataset(std::move(name), path), mSource(std::move(source)) {}

std::string TetMeshDataset::infoJson() const {
  const TetMeshConstants& d = mSource->constants();
  nlohmann::json j = {
      {"kind", std::string(kind())},
      {"tets", d.tetCount},
      {"points", d.pointCount},
      {"field", d.field},
      {"bounds", {{d.bounds.min.x, d.bounds.min.y, d.bounds.min.z}, {d.bounds.max.x, d.bounds.max.y, d.bounds.max.z}}},
      {"value_range", {d.scalarMin, d.scalarMax}},
      {"reference_length", d.meanEdgeLength},
      {"paged", mSource->paged()},
      {"chunks", mSource->chunkCount()}};
  return j.dump();
}

}  // namespace voxbrick::render
