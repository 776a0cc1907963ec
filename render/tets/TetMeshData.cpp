// The tets a frame draws and the constants of their mesh.
#include "render/tets/TetMeshData.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {
namespace {

std::atomic<uint64_t> gNextDataId{1};

}  // namespace

size_t TetMeshData::hostBytes(uint64_t tets, uint64_t points, uint64_t boundaryFaces) {
  return size_t(points * (sizeof(glm::vec3) + sizeof(float)) +
                tets * (sizeof(mesh::Tet) + sizeof(std::array<int32_t, 4>) + sizeof(std::pair<float, float>)) +
                boundaryFaces * sizeof(mesh::BoundaryFace));
}

TetMeshData::TetMeshData(mesh::TetMesh m, mesh::Topology t, const TetMeshConstants& whole)
    : TetMeshConstants(whole), mesh(std::move(m)), topology(std::move(t)), id(gNextDataId++) {
  if (mesh.tets.empty()) throw RenderInputError("tet mesh: no tetrahedra to draw");
  tetRanges.resize(mesh.tets.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh.tets.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const mesh::Tet& tet = mesh.tets[i];
      float tetLo = mesh.scalars[tet[0]], tetHi = tetLo;
      for (int k = 1; k < 4; ++k) {
        tetLo = std::min(tetLo, mesh.scalars[tet[k]]);
        tetHi = std::max(tetHi, mesh.scalars[tet[k]]);
      }
      tetRanges[i] = {tetLo, tetHi};
    }
  });
}

namespace {

/// The constants of a whole mesh, derived from it.
TetMeshConstants constantsOf(const mesh::TetMesh& mesh) {
  if (mesh.tets.empty()) throw RenderInputError("tet mesh: no tetrahedra to draw");
  TetMeshConstants c;
  const auto [lo, hi] = mesh.bounds();
  c.bounds = {glm::dvec3(lo), glm::dvec3(hi)};
  std::tie(c.scalarMin, c.scalarMax) = mesh.scalarRange();
  mesh::EdgeLengths edges;
  for (const mesh::Tet& tet : mesh.tets) edges.add(mesh.points, tet);
  c.meanEdgeLength = edges.mean();
  c.longestEdge = edges.longest;
  c.tetCount = mesh.tets.size();
  c.pointCount = mesh.points.size();
  c.field = mesh.field;
  return c;
}

}  // namespace

void checkEdgeLengths(const TetMeshConstants& c) {
  if (!(c.meanEdgeLength > 0) || !std::isfinite(c.meanEdgeLength))
    throw RenderInputError("tet mesh: its tetrahedra have no size (mean edge length " +
                           std::to_string(c.meanEdgeLength) + ")");
}

TetMeshData::TetMeshData(mesh::TetMesh m, mesh::Topology t) : TetMeshData(std::move(m), std::move(t), {}) {
  static_cast<TetMeshConstants&>(*this) = constantsOf(mesh);
  checkEdgeLengths(*this);
}

}  // namespace voxbrick::render
