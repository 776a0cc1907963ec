// Sort-last rendering's split of a tetrahedral mesh into parts, GL-free: a k-d tree of world-space planes over the
// mesh's box, balanced by weights spread over boxes (a mesh store's chunks and their stored bytes, or a mesh's cells
// one each), so each part is a convex box; the parts' front-to-back order for a camera (render/core/PartOrder.h, as a
// grid's); and a part's cells, those whose extent meets its box, as a mesh of their own.
#pragma once

#include <memory>
#include <vector>

#include <glm/glm.hpp>

#include "mesh/MeshStore.h"
#include "mesh/TetMesh.h"
#include "render/core/Camera.h"
#include "render/core/PartOrder.h"
#include "render/core/PartialFrame.h"
#include "render/core/Scene.h"
#include "render/tets/TetMeshData.h"

namespace voxbrick::render {

/// What a partition balances: a weight spread evenly over a world-space box.
struct WeightedBox {
  glm::dvec3 lo{0.0}, hi{0.0};
  double weight = 0;
};

/// A k-d tree of a mesh's parts.
struct MeshPartition {
  using Node = KdNode<double>;  ///< a split at a world coordinate, or a leaf
  std::vector<Node> nodes;         ///< nodes[0] is the root
  std::vector<MeshPartBox> boxes;  ///< each part's box; faces on the mesh's box pushed out beyond it
  std::vector<double> weights;     ///< each part's share of the weights
};

/// Splits `bounds` (a mesh's box, not empty) into `parts` boxes (1 <= parts <= 65536; throws std::invalid_argument
/// otherwise) balanced by `items`' weights, each item's spread evenly over its box (one of no extent on an axis counts
/// on both sides of a plane through it). Each split halves the parts (the lower side gets parts / 2) across the
/// region's longest axis (ties: the lowest), at the plane where the lower side's weight is its parts' share (the middle
/// of a region that weighs nothing). A box's faces on `bounds` are pushed out by the box's largest extent, so that no
/// cell is cut at the mesh's own surface. The same items, bounds and count give the same partition on every process.
MeshPartition partitionMesh(const std::vector<WeightedBox>& items, const Box& bounds, int parts);

/// A mesh store's chunks as weights: each chunk's box and its stored bytes (what a rank reads to draw it).
std::vector<WeightedBox> chunkWeights(const std::vector<mesh::ChunkInfo>& chunks);
/// A mesh's cells as weights: each tet's box, one each.
std::vector<WeightedBox> cellWeights(const mesh::TetMesh& mesh);

/// `scene`'s camera over a mesh of `constants` as the renderer resolves it (TetView), in world coordinates.
PartView meshPartView(const Scene& scene, const TetMeshConstants& constants);

/// The rectangle of a width × height drawing of `scene` outside which a frame drawn with FrameOptions::meshPart =
/// `part` has nothing: the part's box within the mesh's (the outer parts reach past it), grown by a millionth of
/// the mesh's size, projected by the frame's camera (projectedRect).
PixelRect meshPartFootprint(const MeshPartBox& part, const TetMeshConstants& constants, const Scene& scene, int width,
                            int height);
/// The parts' indices nearest first for `view` (kdFrontToBack).
std::vector<int> partsFrontToBack(const MeshPartition& partition, const PartView& view);

/// Whether the closed box [lo, hi] meets `box` (closed).
bool meets(const MeshPartBox& box, const glm::dvec3& lo, const glm::dvec3& hi);
/// The cells of `data` whose box meets `box`, as a part of `data`'s mesh (TetMeshData's part: `data`'s constants, a
/// face whose neighbour is left out is a boundary face of the part; cells and points keep their order). Null when no
/// cell meets it.
std::shared_ptr<const TetMeshData> cellsMeeting(const TetMeshData& data, const MeshPartBox& box);

}  // namespace voxbrick::render
