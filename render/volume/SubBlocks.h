// Empty-space skipping finer than a brick: the value range of each sub-block of a brick, and the boxes a brick is
// drawn as, front to back, once the transfer function has rejected its empty sub-blocks.
#pragma once

#include <cstdint>
#include <vector>

#include "brickstore/format/Types.h"
#include "brickstore/read/BrickCache.h"
#include "render/core/Camera.h"
#include "render/volume/Traversal.h"

namespace voxbrick::render {

/// A complete octree of value ranges inside one brick: level 0 is the whole brick, level L = log2(B / S) holds the
/// sub-blocks of S^3 voxels. A sub-block owning voxels [a, a + S) per axis is sampled by trilinear reconstruction
/// at samples a - 1 .. a + S (the brick's one-voxel border holds those at the brick's faces), and its range covers
/// exactly those, so skipping a sub-block the transfer function rejects skips nothing that would be drawn.
class SubBlockRanges {
 public:
  struct Range {
    float min = 0, max = 0;
  };

  SubBlockRanges() = default;
  /// `brick` holds (B + 2)^3 samples laid out as BrickStore::readBrick writes them; `owned` is how many voxels the
  /// brick owns per axis (B, or fewer at the volume's far faces). `subBlock` is a power of two below B.
  SubBlockRanges(const store::Brick& brick, int brickSize, int subBlock, const store::Vec3i& owned)
      : SubBlockRanges(brick.data(), brick.type(), brickSize, subBlock, owned) {}
  /// The same from (B + 2)^3 samples of `type`.
  SubBlockRanges(const void* samples, store::ValueType type, int brickSize, int subBlock, const store::Vec3i& owned);

  /// Edge of the finest blocks in voxels; 0 for an empty object.
  int subBlock() const { return mSubBlock; }
  /// Number of levels below the whole brick.
  int levels() const { return mLevels; }
  /// Whether node (level, i, j, k) holds any voxel the brick owns.
  bool exists(int level, int i, int j, int k) const;
  Range range(int level, int i, int j, int k) const;
  /// Voxels per axis a node of `level` spans (before clipping to the owned voxels).
  int edge(int level) const { return mBrickSize >> level; }
  const store::Vec3i& owned() const { return mOwned; }

 private:
  size_t index(int level, int i, int j, int k) const;

  int mBrickSize = 0, mSubBlock = 0, mLevels = 0;
  store::Vec3i mOwned{0, 0, 0};
  std::vector<size_t> mLevelOffset;  // first node of each level in mRanges
  std::vector<Range> mRanges;        // per level, x fastest, (B >> ... ) nodes per axis
};

/// Voxels [lo, hi) of level 0 per axis.
struct VoxelSpan {
  store::Vec3i lo, hi;
};

/// What drawing one brick as sub-block boxes did.
struct SubBlockWalkStats {
  int64_t subBlocksSkipped = 0;  ///< finest blocks the transfer function rejected
  int64_t boxes = 0;             ///< boxes emitted (a node whose blocks all contribute is one box)
};

/// Appends to `out`, front to back, the voxel spans brick `brickLo` (its first voxel, in voxels of pyramid level
/// `level`) is drawn as, in level-0 voxels (a level-m voxel v spans level-0 voxels [v * 2^m, (v + 1) * 2^m), cut at
/// `dims`, level 0's size): nodes whose range `contributes` rejects are left out, and a node whose finest blocks all
/// contribute is one span. The order rule is OctreeTraversal's: per axis, the child on the eye's side of the split
/// first (the view direction's sign for an orthographic camera), with split planes from voxelFace.
void subBlockBoxes(const SubBlockRanges& ranges, const store::Vec3i& brickLo, int level, const store::Vec3i& dims,
                   const store::Vec3d& spacing, const Camera& camera, const RangePredicate& contributes,
                   std::vector<VoxelSpan>& out, SubBlockWalkStats& stats);

}  // namespace voxbrick::render
