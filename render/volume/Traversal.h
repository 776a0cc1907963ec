// Octree traversal: which level-0 bricks to draw, front to back, with empty-space skipping and frustum culling.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "brickstore/format/Types.h"
#include "brickstore/read/MinMaxOctree.h"
#include "render/core/Camera.h"

namespace voxbrick::render {

/// World coordinate of the face between voxels v - 1 and v along an axis of n voxels of spacing s. Every box face
/// of the renderer (bricks, octree nodes, sub-blocks, split planes) comes from this one expression, so boxes that
/// share a face share it bit for bit.
inline double voxelFace(int64_t v, int64_t n, double s) {
  return (static_cast<double>(v) - 0.5 * static_cast<double>(n)) * s;
}

/// The world box of voxels [lo, hi) of a volume of `dims` voxels.
Box voxelSpanBox(const store::Vec3i& lo, const store::Vec3i& hi, const store::Vec3i& dims, const store::Vec3d& spacing);

/// One brick to draw: its key (level 0, or a coarser level of the pyramid standing for the level-0 bricks under it)
/// and the world box of the level-0 voxels it owns (borders excluded). Its samples come from source(): the brick
/// itself, or (coarse-to-fine streaming, Residency::standIn) its ancestor `standIn` levels up, read over the same
/// voxels while the brick itself is still on its way from the disk.
struct BrickDraw {
  store::BrickKey key;
  Box box;
  uint32_t standIn = 0;  ///< levels above key.level that the samples come from (0: the brick itself)

  /// The brick whose samples are drawn.
  store::BrickKey source() const { return {key.level + standIn, key.i >> standIn, key.j >> standIn, key.k >> standIn}; }
};

/// What a traversal did. Skipped and culled count level-0 bricks, including every brick under a skipped or culled
/// node, and so does bricksCoarsened for the nodes drawn at a coarser level: (bricksDrawn - bricksCoarse) +
/// bricksCoarsened + bricksSkippedEmpty + bricksCulled + bricksOutsidePart is the number of bricks of the grid.
struct TraversalStats {
  int64_t nodesVisited = 0;
  int64_t bricksOutsidePart = 0;  ///< under nodes outside TraversalOptions::partBricks (never visited below them)
  int64_t bricksSkippedEmpty = 0;
  int64_t bricksCulled = 0;
  int64_t bricksDrawn = 0;              ///< bricks to draw, of every level
  int64_t bricksCoarse = 0;             ///< of those, bricks of a level above 0
  int64_t bricksCoarsened = 0;          ///< level-0 bricks the coarse ones stand for
  std::vector<int64_t> bricksPerLevel;  ///< bricks to draw of each level (as long as the coarsest one drawn)
};

/// Level of detail by screen-space error. A node of the octree at height m above the leaves covers exactly brick
/// (i, j, k) of pyramid level m, whose voxels are 2^m level-0 voxels across; it is drawn at that level when one of
/// those voxels, at the node's nearest depth along the view axis, is at most `pixels` pixels tall on the image
/// (perspective: at depth z a pixel is 2 z tan(fov / 2) / height world units; orthographic: the view's height over
/// the image's). A node reaching in front of the eye is never coarsened.
struct LevelOfDetail {
  double pixels = 0;    ///< 0: level 0 everywhere
  int coarsest = 0;     ///< the coarsest level that may be drawn (the store's last)
  int imageHeight = 1;  ///< pixels
};

struct TraversalOptions {
  bool skipEmpty = true;    ///< skip nodes whose value range the predicate rejects
  bool cullFrustum = true;  ///< skip nodes whose box lies outside the frustum
  LevelOfDetail lod;        ///< off by default
  /// Sort-last rendering: only the level-0 bricks [lo, hi) (per axis) that meet the rank's part; a node wholly
  /// outside them is left at once, so that a rank walks only its part of the octree. Empty: every brick.
  std::optional<std::array<store::Vec3i, 2>> partBricks;
};

/// Brick key of a node's level -> whether to draw the node at that level whatever the level of detail says (the fit
/// of a frame to its budget, WorkingSet.h).
using DrawWhole = std::function<bool(const store::BrickKey&)>;

/// Raw (not normalised) value range of a node -> whether the transfer function gives it any opacity. It must be
/// monotonic (a range inside an accepted range may be rejected, never the reverse), as TransferFunction::contributes
/// is, for skipping a node to be the same as skipping each of its bricks.
using RangePredicate = std::function<bool(float min, float max)>;

struct TraversalResult {
  std::vector<BrickDraw> bricks;  ///< front to back
  TraversalStats stats;
};

/// Walks a store's min/max octree over level-0 bricks. A brick (i, j, k) owns voxels [i*B, min((i+1)*B, n)) per
/// axis, whose world box is ((lo - n/2) * s, (hi - n/2) * s); a node's box is the union of its bricks' boxes.
///
/// Order: at each node the children are visited front to back, per axis by the side of the node's split plane the
/// eye is on (perspective) or by the sign of the view direction (orthographic). For an axis-aligned grid this is an
/// exact visibility order: whenever a ray from the eye passes through brick A and then brick B, A comes first.
/// A node the predicate rejects is counted as skipped before the frustum is tested.
class OctreeTraversal {
 public:
  /// Keeps a pointer to `octree`, which must outlive this object. Throws RenderInputError unless dims > 0,
  /// brickSize > 0, spacing finite and positive, and octree.bricks() == ceil(dims / brickSize).
  OctreeTraversal(const store::MinMaxOctree& octree, const store::Vec3i& dims, int brickSize,
                  const store::Vec3d& spacing);

  /// The bricks to draw for `camera` (its eye, view direction and projection kind), front to back. `contributes`
  /// may be empty when options.skipEmpty is false; `frustum` is ignored when options.cullFrustum is false. A node
  /// `drawWhole` accepts is drawn at its level (empty: none). Throws RenderInputError for an invalid camera or a
  /// missing predicate.
  TraversalResult run(const Camera& camera, const Frustum& frustum, const RangePredicate& contributes,
                      const TraversalOptions& options = {}, const DrawWhole& drawWhole = {}) const;

  /// World box of brick (i, j, k), which must exist.
  Box brickBox(int64_t i, int64_t j, int64_t k) const;
  /// World box of octree node (d, i, j, k), clipped to the volume; the node must exist.
  Box nodeBox(int d, int64_t i, int64_t j, int64_t k) const;
  /// Whether a node of height `level` with world box `box` may be drawn at that level under `lod` for `camera`.
  bool coarseEnough(const Camera& camera, const LevelOfDetail& lod, int level, const Box& box) const;
  /// How many pixels tall one voxel of level `level` is on an image `imageHeight` pixels high at the nearest depth of
  /// `box` (the screen-space error of drawing the box at that level); infinite when the box reaches in front of the
  /// eye.
  double voxelPixels(const Camera& camera, int imageHeight, int level, const Box& box) const;
  /// The volume's world box (volumeBox(dims, spacing)).
  const Box& volume() const { return mVolume; }

 private:
  struct Walk;
  void visit(Walk& walk, int d, int64_t i, int64_t j, int64_t k) const;

  const store::MinMaxOctree* mOctree;
  store::Vec3i mDims;
  int64_t mBrickSize;
  store::Vec3d mSpacing;
  Box mVolume;
};

}  // namespace voxbrick::render
