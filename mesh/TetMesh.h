// An unstructured tetrahedral mesh in memory: vertices, tetrahedra as four vertex indices, one scalar per vertex.
// What ingest (mesh/MeshReaders.h) produces, the mesh store (mesh/MeshStore.h) keeps and the renderers draw. No GL.
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace voxbrick::mesh {

/// Bad mesh input (a malformed file, indices out of range, a mesh that cannot be repaired): the message names the
/// file, the place in it and what is wrong.
class MeshError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Four vertex indices. After validateMesh() (mesh/Validate.h) every tet is positively oriented: (v1 - v0) x (v2 - v0)
/// . (v3 - v0) > 0.
using Tet = std::array<uint32_t, 4>;

struct TetMesh {
  std::vector<glm::vec3> points;  ///< vertex positions, world units
  std::vector<Tet> tets;
  std::vector<float> scalars;  ///< one per vertex
  std::string field;           ///< the scalar's name in the source file
  /// The cells the reader left out on purpose, "N x KIND, ..." (points, lines and surfaces: no volume); empty if none.
  std::string dropped;

  /// The axis-aligned bounds of the points ({+inf}, {-inf} when there are none).
  std::pair<glm::vec3, glm::vec3> bounds() const;
  /// The smallest and largest scalar (0, 0 when there are none).
  std::pair<float, float> scalarRange() const;
};

/// A part of a mesh whose tets still index the whole mesh's `points` and `scalars`: gives `part` the points its tets
/// use, in the order of their index in the whole (so each tet's vertices keep their order, which the ray caster's
/// walk relies on), and returns each whole-mesh point's index in the part (kNotKept for those left out). The caller
/// renumbers the tets through it.
std::vector<uint32_t> keepUsedPoints(TetMesh& part, const std::vector<glm::vec3>& points,
                                     const std::vector<float>& scalars);
inline constexpr uint32_t kNotKept = ~uint32_t(0);

/// The lengths of tets' edges (six a tet), summed in the order the tets are added: the mean is a mesh's default
/// reference length, the longest bounds a ray's segment in one tet. The same tets added in the same order give the
/// same bits, whether from a whole mesh or chunk by chunk from a store.
struct EdgeLengths {
  double sum = 0;
  double longest = 0;
  uint64_t edges = 0;

  void add(const std::vector<glm::vec3>& points, const Tet& tet);
  double mean() const { return edges > 0 ? sum / double(edges) : 0.0; }
};

}  // namespace voxbrick::mesh
