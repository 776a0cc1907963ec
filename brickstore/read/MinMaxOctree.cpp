// The min/max octree over bricks, built bottom-up from per-brick ranges.
#include "brickstore/read/MinMaxOctree.h"

#include <algorithm>
#include <cassert>
#include <limits>

namespace voxbrick::store {

MinMaxOctree::MinMaxOctree(const Vec3i& bricks, const std::vector<Range>& brickRanges) : mBricks(bricks) {
  assert(static_cast<int64_t>(brickRanges.size()) == bricks.volume());
  int64_t largest = std::max({bricks.x, bricks.y, bricks.z});
  while ((int64_t{1} << mDepth) < largest) ++mDepth;
  mNodes.resize(static_cast<size_t>(mDepth) + 1);
  mNodes[static_cast<size_t>(mDepth)] = brickRanges;
  for (int d = mDepth - 1; d >= 0; --d) {
    Vec3i n = nodesAt(d), c = nodesAt(d + 1);
    const std::vector<Range>& child = mNodes[static_cast<size_t>(d) + 1];
    std::vector<Range>& level = mNodes[static_cast<size_t>(d)];
    level.assign(static_cast<size_t>(n.volume()),
                 Range{std::numeric_limits<float>::max(), std::numeric_limits<float>::lowest()});
    for (int64_t k = 0; k < c.z; ++k)
      for (int64_t j = 0; j < c.y; ++j)
        for (int64_t i = 0; i < c.x; ++i) {
          const Range& r = child[static_cast<size_t>(i + c.x * (j + c.y * k))];
          Range& p = level[static_cast<size_t>(i / 2 + n.x * (j / 2 + n.y * (k / 2)))];
          p.min = std::min(p.min, r.min);
          p.max = std::max(p.max, r.max);
        }
  }
}

Vec3i MinMaxOctree::nodesAt(int d) const {
  int shift = mDepth - d;
  auto up = [shift](int64_t v) { return (v + (int64_t{1} << shift) - 1) >> shift; };
  return {up(mBricks.x), up(mBricks.y), up(mBricks.z)};
}

bool MinMaxOctree::exists(int d, int64_t i, int64_t j, int64_t k) const {
  if (d < 0 || d > mDepth || i < 0 || j < 0 || k < 0) return false;
  Vec3i n = nodesAt(d);
  return i < n.x && j < n.y && k < n.z;
}

MinMaxOctree::Range MinMaxOctree::range(int d, int64_t i, int64_t j, int64_t k) const {
  assert(exists(d, i, j, k));
  Vec3i n = nodesAt(d);
  return mNodes[static_cast<size_t>(d)][static_cast<size_t>(i + n.x * (j + n.y * k))];
}

void MinMaxOctree::brickSpan(int d, int64_t i, int64_t j, int64_t k, Vec3i& lo, Vec3i& hi) const {
  int shift = mDepth - d;
  lo = {i << shift, j << shift, k << shift};
  hi = {std::min((i + 1) << shift, mBricks.x), std::min((j + 1) << shift, mBricks.y),
        std::min((k + 1) << shift, mBricks.z)};
}

}  // namespace voxbrick::store
