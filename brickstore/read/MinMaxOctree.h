// A min/max octree over a grid of bricks: each node holds the min and max of every sample below it.
#pragma once

#include <cstdint>
#include <vector>

#include "brickstore/format/Types.h"

namespace voxbrick::store {

/// Node (d, i, j, k) at depth d covers bricks [i * 2^(D-d), (i+1) * 2^(D-d)) along x (likewise y, z), where D is
/// the depth of the leaves (one leaf per brick). The root is (0, 0, 0, 0). Nodes wholly outside the brick grid do
/// not exist. Values are those of the bricks' samples, borders included, so a node whose range the transfer
/// function maps to zero opacity contributes nothing anywhere inside its box.
class MinMaxOctree {
 public:
  struct Range {
    float min = 0, max = 0;
  };

  MinMaxOctree() = default;
  /// Builds from per-brick ranges, brickRanges[i + bricks.x * (j + bricks.y * k)].
  MinMaxOctree(const Vec3i& bricks, const std::vector<Range>& brickRanges);

  /// Leaf depth D: the smallest D with 2^D >= every brick-grid dimension.
  int depth() const { return mDepth; }
  const Vec3i& bricks() const { return mBricks; }
  /// Number of nodes along each axis at depth d (ceil(bricks / 2^(D-d))).
  Vec3i nodesAt(int d) const;
  /// True if node (d, i, j, k) exists.
  bool exists(int d, int64_t i, int64_t j, int64_t k) const;
  /// The node's range; the node must exist.
  Range range(int d, int64_t i, int64_t j, int64_t k) const;
  /// Bricks covered by node (d, i, j, k), clipped to the grid: [lo, hi).
  void brickSpan(int d, int64_t i, int64_t j, int64_t k, Vec3i& lo, Vec3i& hi) const;

 private:
  Vec3i mBricks;
  int mDepth = 0;
  std::vector<std::vector<Range>> mNodes;  // per depth, x fastest
};

}  // namespace voxbrick::store
