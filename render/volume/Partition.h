// Sort-last rendering's split of a grid dataset into parts, GL-free: a k-d tree over the level-0 bricks, split on
// brick boundaries and balanced by stored bytes (empty bricks cost nothing), so each part is a convex box; and the
// parts' front-to-back order for a camera, which follows from the eye's side of each split.
#pragma once

#include <optional>
#include <vector>

#include <glm/glm.hpp>

#include "brickstore/read/BrickStore.h"
#include "render/core/PartOrder.h"
#include "render/core/PartialFrame.h"
#include "render/core/Scene.h"

namespace voxbrick::render {

class BrickStoreDataset;

/// A k-d tree over a store's level-0 bricks with `parts` leaves.
struct Partition {
  using Node = KdNode<int>;  ///< a split at a level-0 voxel, or a leaf
  std::vector<Node> nodes;      ///< nodes[0] is the root
  std::vector<PartBox> boxes;   ///< each part's box of level-0 voxels, clamped to the volume
  std::vector<uint64_t> bytes;  ///< each part's stored bytes at level 0
};

/// Splits the store's level-0 bricks into `parts` boxes (1 <= parts <= the number of level-0 bricks; throws
/// std::invalid_argument otherwise), balanced by stored bytes; the same store and count give the same partition on
/// every process. Each split halves the parts (the lower side gets parts / 2) across the region's longest axis in
/// bricks (ties: the lowest axis), at a brick boundary whose stored bytes come within one brick's bytes (the largest
/// brick's) of the best balance of the parts' shares: of those the one on the coarsest level's brick boundary, so
/// that fewer coarse bricks are cut between parts (a cut one is drawn by each part, clipped to its box), then the
/// best balanced (ties: the nearest share of bricks, then the lowest position).
Partition partitionBricks(const store::BrickStore& store, int parts);

/// `scene`'s camera resolved over a volume of `meta` as the renderer resolves it (FramePlan), in level-0 voxels
/// (voxel v's centre at v + 0.5), which is what the splits' sides are decided in.
PartView partView(const store::StoreMeta& meta, const Scene& scene);

/// The rectangle of a width × height drawing of `scene` on `meta`'s grid outside which a frame drawn with
/// FrameOptions::part = `part` has nothing: the box grown by a level-0 voxel (a sample belongs to the voxel it lies
/// in) projected by gridCamera (projectedRect), flipped left to right when the store's world frame is mirrored (as
/// finishImage flips the image). With `drawn` (FrameStats::drawnBox of the part's frame), the box is first cut to
/// the bricks the frame drew, grown by a voxel: a part whose box is mostly empty reads only what it drew.
PixelRect partFootprint(const store::StoreMeta& meta, const PartBox& part, const Scene& scene, int width, int height,
                        const std::optional<Box>& drawn = std::nullopt);

/// The parts' indices nearest first for `view` (kdFrontToBack of render/core/PartOrder.h): at each split the side
/// holding the eye (perspective; an eye on the plane takes the lower side first) or the side the view comes from
/// (orthographic, by the direction's sign).
std::vector<int> partsFrontToBack(const Partition& partition, const PartView& view);

/// The parts' indices nearest first for `scene`'s camera over `dataset` (perspective: the eye's side of each split;
/// orthographic: the view direction's sign on the split's axis; a camera inside the volume works).
std::vector<int> partsFrontToBack(const Partition& partition, const BrickStoreDataset& dataset, const Scene& scene);

}  // namespace voxbrick::render
