// Mesh datasets: the per-mesh constants every frame uses.
#include "render/TetDataset.h"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "render/RenderErrors.h"

namespace voxbrick::render {

size_t TetMeshData::hostBytes(uint64_t tets, uint64_t points, uint64_t boundaryFaces) {
  return size_t(points * (sizeof(glm::vec3) + sizeof(float)) +
                tets * (sizeof(mesh::Tet) + sizeof(std::array<int32_t, 4>) + sizeof(std::pair<float, float>)) +
                boundaryFaces * sizeof(mesh::BoundaryFace));
}

TetMeshData::TetMeshData(mesh::TetMesh m, mesh::Topology t) : mesh(std::move(m)), topology(std::move(t)) {
  if (mesh.tets.empty()) throw RenderInputError("tet mesh: no tetrahedra to draw");
  const auto [lo, hi] = mesh.bounds();
  bounds = {glm::dvec3(lo), glm::dvec3(hi)};
  const auto [smin, smax] = mesh.scalarRange();
  scalarMin = smin;
  scalarMax = smax;
  double sum = 0, longest = 0;
  tetRanges.reserve(mesh.tets.size());
  for (const mesh::Tet& tet : mesh.tets) {
    float tetLo = mesh.scalars[tet[0]], tetHi = tetLo;
    for (int i = 1; i < 4; ++i) {
      tetLo = std::min(tetLo, mesh.scalars[tet[i]]);
      tetHi = std::max(tetHi, mesh.scalars[tet[i]]);
    }
    tetRanges.emplace_back(tetLo, tetHi);
  }
  for (const mesh::Tet& tet : mesh.tets)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        const double length = glm::length(glm::dvec3(mesh.points[tet[a]]) - glm::dvec3(mesh.points[tet[b]]));
        sum += length;
        longest = std::max(longest, length);
      }
  meanEdgeLength = sum / (6.0 * double(mesh.tets.size()));
  longestEdge = longest;
  if (!(meanEdgeLength > 0) || !std::isfinite(meanEdgeLength))
    throw RenderInputError("tet mesh: its tetrahedra have no size (mean edge length " + std::to_string(meanEdgeLength) +
                           ")");
}

TetMeshDataset::TetMeshDataset(std::string name, const std::filesystem::path& path,
                               std::shared_ptr<const TetMeshData> data)
    : Dataset(std::move(name), path), mData(std::move(data)) {}

std::string TetMeshDataset::infoJson() const {
  const TetMeshData& d = *mData;
  nlohmann::json j = {{"kind", datasetKindName(kind())},
                      {"tets", d.mesh.tets.size()},
                      {"points", d.mesh.points.size()},
                      {"field", d.mesh.field},
                      {"bounds", {{d.bounds.min.x, d.bounds.min.y, d.bounds.min.z},
                                  {d.bounds.max.x, d.bounds.max.y, d.bounds.max.z}}},
                      {"value_range", {d.scalarMin, d.scalarMax}},
                      {"reference_length", d.meanEdgeLength}};
  return j.dump();
}

}  // namespace voxbrick::render
