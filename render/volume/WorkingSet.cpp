// Coarsening a frame's bricks, cheapest parents first, until they fit the budget.
#include "render/volume/WorkingSet.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <tuple>
#include <unordered_map>

namespace voxbrick::render {
namespace {

store::BrickKey parentOf(const store::BrickKey& key) { return {key.level + 1, key.i >> 1, key.j >> 1, key.k >> 1}; }

/// The bit of `key` among its parent's eight children.
uint8_t childBit(const store::BrickKey& key) {
  return uint8_t(1u << ((key.i & 1) | ((key.j & 1) << 1) | ((key.k & 1) << 2)));
}

struct KeyHash {
  size_t operator()(const store::BrickKey& k) const {
    uint64_t h = k.level;
    for (uint32_t v : {k.i, k.j, k.k}) h = h * 0x9E3779B97F4A7C15ull + v;
    return size_t(h ^ (h >> 29));
  }
};

/// A candidate parent: its drawn children, and which of its children are drawn finer (subdivided) still.
struct Parent {
  int64_t drawnChildren = 0;
  uint8_t subdivided = 0;
};

struct Candidate {
  double cost;
  store::BrickKey node;
  /// Greater first out of a std::priority_queue: the cheapest, then the finest, then the lowest index.
  bool operator<(const Candidate& o) const {
    if (cost != o.cost) return cost > o.cost;
    return keyLess(o.node, node);
  }
};

}  // namespace

int64_t BrickBudget::limit() const {
  if (atlasBricks > 0 && hostBricks > 0) return std::min(atlasBricks, hostBricks);
  return std::max(atlasBricks, hostBricks);
}

bool keyLess(const store::BrickKey& a, const store::BrickKey& b) {
  return std::tie(a.level, a.k, a.j, a.i) < std::tie(b.level, b.k, b.j, b.i);
}

double CoarseningCost::operator()(const store::MinMaxOctree& octree, const store::BrickKey& node) const {
  const int d = octree.depth() - int(node.level);
  const Box box = traversal.nodeBox(d, node.i, node.j, node.k);
  const double pixels = traversal.voxelPixels(camera, imageHeight, int(node.level), box);
  if (!std::isfinite(pixels)) return std::numeric_limits<double>::infinity();
  const store::MinMaxOctree::Range range = octree.range(d, node.i, node.j, node.k);
  const double alpha = opacity ? opacity(range.min, range.max) : 1.0;
  return pixels * (std::clamp(alpha, 0.0, 1.0) + kOpacityFloor);
}

std::vector<store::BrickKey> coarsenToFit(const std::vector<BrickDraw>& bricks, const store::MinMaxOctree& octree,
                                          int coarsest, const CoarseningCost& cost, int64_t capacity) {
  coarsest = std::min(coarsest, octree.depth());
  int64_t count = int64_t(bricks.size());
  std::vector<store::BrickKey> chosen;
  if (capacity <= 0 || count <= capacity) return chosen;
  // Every parent of a drawn brick, and above it every ancestor learns which of its children are subdivided.
  std::unordered_map<store::BrickKey, Parent, KeyHash> parents;
  for (const BrickDraw& b : bricks) {
    if (int(b.key.level) >= coarsest) continue;
    store::BrickKey node = parentOf(b.key);
    ++parents[node].drawnChildren;
    while (int(node.level) < coarsest) {
      Parent& above = parents[parentOf(node)];
      if (above.subdivided & childBit(node)) break;  // the ancestors above know already
      above.subdivided |= childBit(node);
      node = parentOf(node);
    }
  }
  std::vector<Candidate> ready;
  for (const auto& [node, p] : parents)
    if (p.subdivided == 0 && p.drawnChildren > 0) ready.push_back({cost(octree, node), node});
  std::priority_queue<Candidate> queue(std::less<Candidate>{}, std::move(ready));
  while (count > capacity && !queue.empty()) {
    const store::BrickKey node = queue.top().node;
    queue.pop();
    count -= parents[node].drawnChildren - 1;
    chosen.push_back(node);
    if (int(node.level) >= coarsest) continue;
    Parent& above = parents[parentOf(node)];
    ++above.drawnChildren;
    above.subdivided &= uint8_t(~childBit(node));
    if (above.subdivided == 0) queue.push({cost(octree, parentOf(node)), parentOf(node)});
  }
  std::sort(chosen.begin(), chosen.end(), keyLess);
  return chosen;
}

DrawWhole drawWholeTest(const std::vector<store::BrickKey>& nodes) {
  if (nodes.empty()) return {};
  return [&nodes](const store::BrickKey& key) { return std::binary_search(nodes.begin(), nodes.end(), key, keyLess); };
}

}  // namespace voxbrick::render
