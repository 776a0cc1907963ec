// A tetrahedral mesh as a dataset (seed 002): the mesh, its face adjacency, and what every frame of it needs (its
// world box, the default reference length), held in memory and shared read-only by every render thread. GL-free.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "mesh/TetMesh.h"
#include "mesh/Topology.h"
#include "render/Camera.h"
#include "render/Dataset.h"

namespace voxbrick::render {

/// A mesh ready to draw. Built once per dataset.
struct TetMeshData {
  mesh::TetMesh mesh;
  mesh::Topology topology;
  Box bounds;                     ///< the points' box, world units (the camera orbits its centre)
  double meanEdgeLength = 1;      ///< over every tet's six edges: the default reference length (a "cell")
  double longestEdge = 1;         ///< the longest segment a ray can have in one tet
  float scalarMin = 0, scalarMax = 0;
  /// Per tet, the smallest and largest of its four scalars: the values inside it (linear) lie between, so a tet the
  /// transfer function makes transparent over that range adds nothing and is not drawn.
  std::vector<std::pair<float, float>> tetRanges;

  /// Derives the box, lengths and range from `mesh` (which must hold at least one tet with valid indices).
  TetMeshData(mesh::TetMesh mesh, mesh::Topology topology);

  /// The host bytes a mesh of these counts takes held whole: points and scalars (16 a point), tets, neighbours and
  /// value ranges (40 a tet), boundary faces (8 each).
  static size_t hostBytes(uint64_t tets, uint64_t points, uint64_t boundaryFaces);
};

/// A mesh dataset: what the server and `render` open; RenderEngine draws it with a TetRenderer.
class TetMeshDataset final : public Dataset {
 public:
  /// A dataset of `data` (already loaded) under `name`, read from `path`.
  TetMeshDataset(std::string name, const std::filesystem::path& path, std::shared_ptr<const TetMeshData> data);

  DatasetKind kind() const override { return DatasetKind::TetMesh; }
  /// {"kind": "tet-mesh", "tets", "points", "field", "bounds", "value_range", "reference_length"}.
  std::string infoJson() const override;
  /// A mesh is held whole in memory: no cache.
  store::CacheStats cacheStats() const override { return {}; }
  void setCacheBudget(size_t) const override {}

  const std::shared_ptr<const TetMeshData>& data() const { return mData; }

 private:
  std::shared_ptr<const TetMeshData> mData;
};

}  // namespace voxbrick::render
