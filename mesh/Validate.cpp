#include "mesh/Validate.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

namespace voxbrick::mesh {

namespace {

std::string formatVec(const glm::vec3& p) {
  return "(" + std::to_string(p.x) + ", " + std::to_string(p.y) + ", " + std::to_string(p.z) + ")";
}

}  // namespace

double orientedVolume6(const TetMesh& mesh, const Tet& tet) {
  // In double: float coordinates and their differences are exact there, so the sign is right for any tet above
  // the degeneracy threshold, far above double's rounding.
  const glm::dvec3 p0(mesh.points[tet[0]]);
  const glm::dvec3 a = glm::dvec3(mesh.points[tet[1]]) - p0;
  const glm::dvec3 b = glm::dvec3(mesh.points[tet[2]]) - p0;
  const glm::dvec3 c = glm::dvec3(mesh.points[tet[3]]) - p0;
  return glm::dot(glm::cross(a, b), c);
}

MeshRepairs validateMesh(TetMesh& mesh) {
  if (mesh.tets.empty()) throw MeshError("validateMesh: the mesh has no tetrahedra");
  if (mesh.scalars.size() != mesh.points.size())
    throw MeshError("validateMesh: " + std::to_string(mesh.scalars.size()) + " scalars for " +
                    std::to_string(mesh.points.size()) + " vertices");
  for (size_t v = 0; v < mesh.points.size(); ++v) {
    const glm::vec3& p = mesh.points[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw MeshError("validateMesh: vertex " + std::to_string(v) + " has a non-finite position " + formatVec(p));
    if (!std::isfinite(mesh.scalars[v]))
      throw MeshError("validateMesh: vertex " + std::to_string(v) + " has a non-finite scalar (" +
                      std::to_string(mesh.scalars[v]) + ")");
  }
  for (size_t t = 0; t < mesh.tets.size(); ++t)
    for (uint32_t v : mesh.tets[t])
      if (v >= mesh.points.size())
        throw MeshError("validateMesh: tet " + std::to_string(t) + " uses vertex " + std::to_string(v) +
                        ", but the mesh has " + std::to_string(mesh.points.size()) + " vertices");

  // Relative to the mesh's size, so that the rule does not depend on its units.
  const auto [lo, hi] = mesh.bounds();
  const glm::dvec3 extent = glm::dvec3(hi) - glm::dvec3(lo);
  const double size = std::max({extent.x, extent.y, extent.z});
  const double threshold = 6.0 * kDegenerateVolume * size * size * size;

  MeshRepairs repairs;
  size_t kept = 0;
  for (size_t t = 0; t < mesh.tets.size(); ++t) {
    Tet tet = mesh.tets[t];
    const bool repeated = tet[0] == tet[1] || tet[0] == tet[2] || tet[0] == tet[3] || tet[1] == tet[2] ||
                          tet[1] == tet[3] || tet[2] == tet[3];
    const double volume6 = repeated ? 0.0 : orientedVolume6(mesh, tet);
    if (repeated || std::abs(volume6) <= threshold) {
      ++repairs.removedDegenerate;
      continue;
    }
    if (volume6 < 0) {
      std::swap(tet[2], tet[3]);
      ++repairs.flipped;
    }
    mesh.tets[kept++] = tet;
  }
  mesh.tets.resize(kept);
  if (mesh.tets.empty())
    throw MeshError("validateMesh: all " + std::to_string(repairs.removedDegenerate) + " tetrahedra are degenerate");

  std::vector<uint8_t> used(mesh.points.size(), 0);
  for (const Tet& tet : mesh.tets)
    for (uint32_t v : tet) used[v] = 1;
  repairs.unreferencedVertices = static_cast<size_t>(std::count(used.begin(), used.end(), uint8_t{0}));
  return repairs;
}

}  // namespace voxbrick::mesh
