// Sort-last rendering's split of a grid dataset into parts, GL-free: a k-d tree over the level-0 bricks, split on
// brick boundaries and balanced by stored bytes (empty bricks cost nothing), so each part is a convex box; and the
// parts' front-to-back order for a camera, which follows from the eye's side of each split.
#pragma once

#include <vector>

#include "brickstore/BrickStore.h"
#include "render/core/PartialFrame.h"
#include "render/core/Scene.h"

namespace voxbrick::render {

class BrickStoreDataset;

/// A k-d tree over a store's level-0 bricks with `parts` leaves.
struct Partition {
  /// One node: a split (axis 0..2 at level-0 voxel `position`, children `lower` and `upper`), or a leaf (part >= 0).
  struct Node {
    int axis = -1;
    int position = 0;
    int lower = -1, upper = -1;
    int part = -1;
  };
  std::vector<Node> nodes;      ///< nodes[0] is the root
  std::vector<PartBox> boxes;   ///< each part's box of level-0 voxels, clamped to the volume
  std::vector<uint64_t> bytes;  ///< each part's stored bytes at level 0
};

/// Splits the store's level-0 bricks into `parts` boxes (1 <= parts <= the number of bricks along the volume),
/// balanced by stored bytes; the same store and count give the same partition on every process.
Partition partitionBricks(const store::BrickStore& store, int parts);

/// The parts' indices nearest first for `scene`'s camera over `dataset` (perspective: the eye's side of each split;
/// orthographic: the view direction's sign on the split's axis; a camera inside the volume works).
std::vector<int> partsFrontToBack(const Partition& partition, const BrickStoreDataset& dataset, const Scene& scene);

}  // namespace voxbrick::render
