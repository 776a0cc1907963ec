// Sort-last rendering's partition of a grid dataset: the k-d tree over level-0 bricks balanced by stored bytes, and
// the parts' visibility order for a camera.
#include "render/volume/Partition.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "render/core/Camera.h"
#include "render/volume/BrickStoreDataset.h"
#include "render/volume/FramePlan.h"

namespace voxbrick::render {
namespace {

/// A region of level-0 bricks, half-open.
struct BrickRegion {
  std::array<int64_t, 3> lo{}, hi{};
  int64_t extent(int a) const { return hi[size_t(a)] - lo[size_t(a)]; }
  int64_t count() const { return extent(0) * extent(1) * extent(2); }
};

/// The stored bytes of every level-0 brick, x fastest.
struct BrickCosts {
  store::Vec3i grid;
  std::vector<uint64_t> bytes;
  uint64_t largest = 0;  ///< the largest brick's bytes: how far from the best balance a split may be to align
  int coarsest = 0;      ///< the store's coarsest level: no alignment counts beyond its bricks

  uint64_t at(int64_t i, int64_t j, int64_t k) const { return bytes[size_t(i + grid.x * (j + grid.y * k))]; }
  /// The bytes of each slab of `region` across `axis`, one per brick along it.
  std::vector<uint64_t> slabs(const BrickRegion& region, int axis) const {
    std::vector<uint64_t> out(size_t(region.extent(axis)), 0);
    for (int64_t k = region.lo[2]; k < region.hi[2]; ++k)
      for (int64_t j = region.lo[1]; j < region.hi[1]; ++j)
        for (int64_t i = region.lo[0]; i < region.hi[0]; ++i) {
          const int64_t along = (axis == 0 ? i : axis == 1 ? j : k) - region.lo[size_t(axis)];
          out[size_t(along)] += at(i, j, k);
        }
    return out;
  }
};

/// A split of a region: the axis, the first brick of the upper side along it, and the parts of the lower side.
struct Split {
  int axis = -1;
  int64_t at = 0;
  int lowerParts = 0;
};

/// The best split of `region` into `parts` (>= 2) along `axis` with `lowerParts` parts below, or axis -1 if no
/// position leaves each side at least one brick per part. Best: among the positions within one brick's bytes of the
/// best balance, the one on the coarsest level's brick boundary (so that fewer coarse bricks are cut between parts
/// and drawn by both), then the best balanced, then the nearest share of bricks, then the lowest.
Split bestSplit(const BrickCosts& costs, const BrickRegion& region, int parts, int axis, int lowerParts) {
  const int64_t extent = region.extent(axis), area = region.count() / std::max<int64_t>(extent, 1);
  const std::vector<uint64_t> slabs = costs.slabs(region, axis);
  uint64_t total = 0;
  for (uint64_t b : slabs) total += b;
  struct Candidate {
    int64_t at;
    double bytes, bricks;  // how far the lower side's share is from its parts' share, in bytes and in bricks
    int aligned;           // the coarsest level whose brick boundary it lies on
  };
  std::vector<Candidate> candidates;
  const double share = double(lowerParts) / parts;
  uint64_t lower = 0;
  double bestBytes = 0;
  for (int64_t p = 1; p < extent; ++p) {
    lower += slabs[size_t(p - 1)];
    if (p * area < lowerParts || (extent - p) * area < parts - lowerParts) continue;
    const int64_t at = region.lo[size_t(axis)] + p;
    const Candidate c{at, std::abs(double(lower) - share * double(total)), std::abs(double(p) - share * double(extent)),
                      std::min(std::countr_zero(uint64_t(at)), costs.coarsest)};
    bestBytes = candidates.empty() ? c.bytes : std::min(bestBytes, c.bytes);
    candidates.push_back(c);
  }
  Split best;
  const Candidate* chosen = nullptr;
  for (const Candidate& c : candidates) {
    if (c.bytes > bestBytes + double(costs.largest)) continue;
    if (!chosen || c.aligned > chosen->aligned ||
        (c.aligned == chosen->aligned &&
         (c.bytes < chosen->bytes || (c.bytes == chosen->bytes && c.bricks < chosen->bricks))))
      chosen = &c;
  }
  if (chosen) best = {axis, chosen->at, lowerParts};
  return best;
}

/// The split of `region` into `parts` (>= 2, at most its bricks): the longest axis first (ties: the lowest), half
/// the parts on each side; where no axis allows that, the parts in proportion to the bricks on each side.
Split chooseSplit(const BrickCosts& costs, const BrickRegion& region, int parts) {
  std::array<int, 3> axes{0, 1, 2};
  std::stable_sort(axes.begin(), axes.end(), [&](int a, int b) { return region.extent(a) > region.extent(b); });
  for (int axis : axes)
    if (region.extent(axis) > 1) {
      const Split split = bestSplit(costs, region, parts, axis, parts / 2);
      if (split.axis >= 0) return split;
    }
  // Few bricks for many parts: the middle of the longest axis, the parts shared by the bricks on each side.
  const int axis = axes[0];
  const int64_t extent = region.extent(axis), area = region.count() / extent, p = extent / 2;
  const int64_t lowerBricks = p * area, upperBricks = (extent - p) * area;
  int64_t lowerParts = (int64_t(parts) * lowerBricks + region.count() / 2) / region.count();
  lowerParts = std::clamp<int64_t>(lowerParts, std::max<int64_t>(1, parts - upperBricks),
                                   std::min<int64_t>(lowerBricks, parts - 1));
  return {axis, region.lo[size_t(axis)] + p, int(lowerParts)};
}

/// Builds the subtree of `region` with `parts` leaves numbered from `firstPart`; returns its node's index.
int build(Partition& partition, const BrickCosts& costs, const BrickRegion& region, int parts, int firstPart,
          const store::Vec3i& dims, int brickSize) {
  const int index = int(partition.nodes.size());
  partition.nodes.emplace_back();
  if (parts == 1) {
    partition.nodes[size_t(index)].part = firstPart;
    PartBox box;
    uint64_t bytes = 0;
    for (int a = 0; a < 3; ++a) {
      box.lo[size_t(a)] = int(std::min(region.lo[size_t(a)] * brickSize, dims[a]));
      box.hi[size_t(a)] = int(std::min(region.hi[size_t(a)] * brickSize, dims[a]));
    }
    for (int64_t k = region.lo[2]; k < region.hi[2]; ++k)
      for (int64_t j = region.lo[1]; j < region.hi[1]; ++j)
        for (int64_t i = region.lo[0]; i < region.hi[0]; ++i) bytes += costs.at(i, j, k);
    partition.boxes[size_t(firstPart)] = box;
    partition.bytes[size_t(firstPart)] = bytes;
    return index;
  }
  const Split split = chooseSplit(costs, region, parts);
  BrickRegion lower = region, upper = region;
  lower.hi[size_t(split.axis)] = split.at;
  upper.lo[size_t(split.axis)] = split.at;
  const int lowerNode = build(partition, costs, lower, split.lowerParts, firstPart, dims, brickSize);
  const int upperNode =
      build(partition, costs, upper, parts - split.lowerParts, firstPart + split.lowerParts, dims, brickSize);
  Partition::Node& node = partition.nodes[size_t(index)];
  node.axis = split.axis;
  node.position = int(split.at * brickSize);
  node.lower = lowerNode;
  node.upper = upperNode;
  return index;
}

}  // namespace

Partition partitionBricks(const store::BrickStore& store, int parts) {
  const store::LevelMeta& level0 = store.level(0);
  const store::Vec3i grid = level0.bricks;
  if (parts < 1 || parts > grid.volume())
    throw std::invalid_argument("a partition into " + std::to_string(parts) + " parts needs between 1 and " +
                                std::to_string(grid.volume()) + " (the level-0 bricks)");
  BrickCosts costs{grid, std::vector<uint64_t>(size_t(grid.volume()), 0), 0, store.levelCount() - 1};
  for (int64_t k = 0; k < grid.z; ++k)
    for (int64_t j = 0; j < grid.y; ++j)
      for (int64_t i = 0; i < grid.x; ++i)
        costs.bytes[size_t(i + grid.x * (j + grid.y * k))] =
            store.record({0, uint32_t(i), uint32_t(j), uint32_t(k)}).compressedSize;
  for (uint64_t b : costs.bytes) costs.largest = std::max(costs.largest, b);
  Partition partition;
  partition.boxes.resize(size_t(parts));
  partition.bytes.resize(size_t(parts));
  BrickRegion all;
  all.hi = {grid.x, grid.y, grid.z};
  build(partition, costs, all, parts, 0, level0.dims, store.brickSize());
  return partition;
}

PartView partView(const store::StoreMeta& meta, const Scene& scene) {
  // The camera as planFrame resolves it; a voxel coordinate is world / spacing + dims / 2.
  const Camera camera = gridCamera(scene, meta);
  const glm::dvec3 spacing(meta.spacing.x, meta.spacing.y, meta.spacing.z);
  const glm::dvec3 dims(double(meta.dims.x), double(meta.dims.y), double(meta.dims.z));
  PartView view;
  view.orthographic = camera.orthographic;
  view.eye = camera.eye / spacing + 0.5 * dims;
  view.direction = camera.viewDirection() / spacing;
  return view;
}

PixelRect partFootprint(const store::StoreMeta& meta, const PartBox& part, const Scene& scene, int width, int height,
                        const std::optional<Box>& drawn) {
  // In the local frame the renderers draw in: a voxel coordinate is local / spacing + dims / 2.
  const double dims[3] = {double(meta.dims.x), double(meta.dims.y), double(meta.dims.z)};
  const double spacing[3] = {meta.spacing.x, meta.spacing.y, meta.spacing.z};
  Box box;
  for (int a = 0; a < 3; ++a) {
    box.min[a] = (double(part.lo[size_t(a)]) - 1 - 0.5 * dims[a]) * spacing[a];
    box.max[a] = (double(part.hi[size_t(a)]) + 1 - 0.5 * dims[a]) * spacing[a];
    if (drawn) {
      box.min[a] = std::max(box.min[a], drawn->min[a] - spacing[a]);
      box.max[a] = std::min(box.max[a], drawn->max[a] + spacing[a]);
      if (box.min[a] > box.max[a]) return {};  // nothing drawn (or nothing of the part)
    }
  }
  const PixelRect r = projectedRect(gridCamera(scene, meta), box, width, height);
  if (r.empty() || !WorldFrame::of(meta.orientation, meta.dims, meta.spacing).mirrored()) return r;
  return {width - r.x1, r.y0, width - r.x0, r.y1};
}

std::vector<int> partsFrontToBack(const Partition& partition, const PartView& view) {
  return kdFrontToBack(partition.nodes, view);
}

std::vector<int> partsFrontToBack(const Partition& partition, const BrickStoreDataset& dataset, const Scene& scene) {
  return partsFrontToBack(partition, partView(dataset.store()->meta(), scene));
}

}  // namespace voxbrick::render
