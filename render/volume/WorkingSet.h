// Fitting a frame's working set to its budget: when the bricks the level of detail chose need more room than the GPU
// atlas (or the host cache) holds, groups of sibling bricks are drawn as their parent, where that costs least, until
// the frame fits. A frame that fits is then resident whole, and the next frame of the same view pages nothing.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "brickstore/read/MinMaxOctree.h"
#include "render/volume/Traversal.h"

namespace voxbrick::render {

/// How many bricks a frame may draw and still keep them all: the GPU atlas's slots (in bricks of its format) and the
/// bricks the host cache's budget holds. 0: no limit.
struct BrickBudget {
  int64_t atlasBricks = 0;
  int64_t hostBricks = 0;

  /// The smaller of the two limits that are set; 0 when neither is.
  int64_t limit() const;
};

/// Raw value range of a node -> the largest opacity the transfer function gives a value in it.
using RangeOpacity = std::function<double(float min, float max)>;

/// The error of drawing a node one level coarser: how many pixels one of its voxels at that level covers (at the
/// node's nearest depth) times the node's largest opacity, plus a floor so that nearly transparent nodes are still
/// taken far ones first. Infinite for a node reaching in front of the eye (taken last).
struct CoarseningCost {
  const OctreeTraversal& traversal;
  const Camera& camera;
  int imageHeight = 1;
  RangeOpacity opacity;

  static constexpr double kOpacityFloor = 1.0 / 256;
  double operator()(const store::MinMaxOctree& octree, const store::BrickKey& node) const;
};

/// The nodes to draw whole so that `bricks` (a traversal's front-to-back bricks, each a node of the octree) need at
/// most `capacity` bricks: a parent whose drawn descendants are all its children is a candidate, taken cheapest first
/// (CoarseningCost, ties by level and index, so the choice is deterministic), its children replaced by it, which may
/// make its own parent a candidate; up to level `coarsest`. O(n log n) in the bricks. Empty when they fit already;
/// when even the coarsest levels do not fit, as close as the levels allow (the frame is then drawn in batches).
/// Sorted, for drawWholeTest.
std::vector<store::BrickKey> coarsenToFit(const std::vector<BrickDraw>& bricks, const store::MinMaxOctree& octree,
                                          int coarsest, const CoarseningCost& cost, int64_t capacity);

/// The traversal's DrawWhole test for coarsenToFit's sorted nodes (which the returned function references).
DrawWhole drawWholeTest(const std::vector<store::BrickKey>& nodes);

/// Orders brick keys by level, then k, j, i.
bool keyLess(const store::BrickKey& a, const store::BrickKey& b);

}  // namespace voxbrick::render
