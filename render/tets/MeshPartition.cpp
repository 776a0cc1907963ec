// Sort-last rendering's partition of a tetrahedral mesh: world-space k-d planes balanced by weights spread over boxes,
// the parts' visibility order for a camera, and a part's cells.
#include "render/tets/MeshPartition.h"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "render/tets/TetView.h"

namespace voxbrick::render {
namespace {

constexpr int kMaxParts = 65536;

/// A region of world space, closed.
struct Region {
  glm::dvec3 lo{0.0}, hi{0.0};
};

/// The share of `item`'s extent on `axis` inside [lo, hi]: an item of no extent there is wholly in or out.
double fractionIn(const WeightedBox& item, int axis, double lo, double hi) {
  const double a = item.lo[axis], b = item.hi[axis];
  if (!(b > a)) return a >= lo && a <= hi ? 1.0 : 0.0;
  return std::clamp((std::min(hi, b) - std::max(lo, a)) / (b - a), 0.0, 1.0);
}

/// An item's weight inside a region, and its stretch along the split axis clipped to the region.
struct Clipped {
  double weight = 0;
  double lo = 0, hi = 0;
};

/// The plane across `axis` of `region` below which the clipped items weigh `share` of their total (the middle when
/// they weigh nothing): bisection over the weight below a plane, which only grows with the plane's position.
double balancedPlane(const std::vector<Clipped>& items, const Region& region, int axis, double share) {
  double total = 0;
  for (const Clipped& c : items) total += c.weight;
  const double lo = region.lo[axis], hi = region.hi[axis];
  if (!(total > 0)) return 0.5 * (lo + hi);
  auto below = [&](double plane) {
    double w = 0;
    for (const Clipped& c : items) {
      if (plane >= c.hi)
        w += c.weight;
      else if (plane > c.lo)
        w += c.weight * (plane - c.lo) / (c.hi - c.lo);
    }
    return w;
  };
  const double target = share * total;
  double a = lo, b = hi;
  for (int i = 0; i < 100 && b > a; ++i) {
    const double m = 0.5 * (a + b);
    if (m <= a || m >= b) break;
    (below(m) < target ? a : b) = m;
  }
  return 0.5 * (a + b);
}

struct Builder {
  const std::vector<WeightedBox>& items;
  Region root;
  double margin = 1;
  MeshPartition partition;

  /// The subtree of `region` with `parts` leaves numbered from `firstPart`, over `inside` (the items meeting it);
  /// returns its node's index.
  int build(const Region& region, const std::vector<uint32_t>& inside, int parts, int firstPart) {
    const int index = int(partition.nodes.size());
    partition.nodes.emplace_back();
    if (parts == 1) {
      partition.nodes[size_t(index)].part = firstPart;
      MeshPartBox box;
      double weight = 0;
      for (uint32_t i : inside) {
        double w = items[i].weight;
        for (int a = 0; a < 3; ++a) w *= fractionIn(items[i], a, region.lo[a], region.hi[a]);
        weight += w;
      }
      for (int a = 0; a < 3; ++a) {
        box.lo[size_t(a)] = region.lo[a] <= root.lo[a] ? root.lo[a] - margin : region.lo[a];
        box.hi[size_t(a)] = region.hi[a] >= root.hi[a] ? root.hi[a] + margin : region.hi[a];
      }
      partition.boxes[size_t(firstPart)] = box;
      partition.weights[size_t(firstPart)] = weight;
      return index;
    }
    int axis = 0;
    const glm::dvec3 extent = region.hi - region.lo;
    for (int a = 1; a < 3; ++a)
      if (extent[a] > extent[axis]) axis = a;
    std::vector<Clipped> clipped;
    clipped.reserve(inside.size());
    for (uint32_t i : inside) {
      const WeightedBox& item = items[i];
      Clipped c;
      c.weight = item.weight;
      for (int a = 0; a < 3; ++a)
        if (a != axis) c.weight *= fractionIn(item, a, region.lo[a], region.hi[a]);
      // Along the axis, the item's stretch inside the region carries its weight there.
      c.weight *= fractionIn(item, axis, region.lo[axis], region.hi[axis]);
      c.lo = std::max(item.lo[axis], region.lo[axis]);
      c.hi = std::min(item.hi[axis], region.hi[axis]);
      clipped.push_back(c);
    }
    const int lowerParts = parts / 2;
    const double plane = balancedPlane(clipped, region, axis, double(lowerParts) / parts);
    Region lower = region, upper = region;
    lower.hi[axis] = plane;
    upper.lo[axis] = plane;
    std::vector<uint32_t> lowerItems, upperItems;
    for (uint32_t i : inside) {
      if (items[i].lo[axis] <= plane) lowerItems.push_back(i);
      if (items[i].hi[axis] >= plane) upperItems.push_back(i);
    }
    const int lowerNode = build(lower, lowerItems, lowerParts, firstPart);
    const int upperNode = build(upper, upperItems, parts - lowerParts, firstPart + lowerParts);
    MeshPartition::Node& node = partition.nodes[size_t(index)];
    node.axis = axis;
    node.position = plane;
    node.lower = lowerNode;
    node.upper = upperNode;
    return index;
  }
};

}  // namespace

MeshPartition partitionMesh(const std::vector<WeightedBox>& items, const Box& bounds, int parts) {
  if (parts < 1 || parts > kMaxParts)
    throw std::invalid_argument("a mesh's partition into " + std::to_string(parts) + " parts needs between 1 and " +
                                std::to_string(kMaxParts));
  for (int a = 0; a < 3; ++a)
    if (!(bounds.max[a] >= bounds.min[a]))
      throw std::invalid_argument("a mesh's partition needs a box with max >= min on every axis");
  Builder builder{items, {bounds.min, bounds.max}, 1.0, {}};
  const glm::dvec3 extent = bounds.max - bounds.min;
  builder.margin = std::max({extent.x, extent.y, extent.z, 1e-30}) + 1.0;
  builder.partition.boxes.resize(size_t(parts));
  builder.partition.weights.resize(size_t(parts));
  std::vector<uint32_t> all;
  all.reserve(items.size());
  for (size_t i = 0; i < items.size(); ++i)
    if (items[i].weight > 0) all.push_back(uint32_t(i));
  builder.build(builder.root, all, parts, 0);
  return std::move(builder.partition);
}

std::vector<WeightedBox> chunkWeights(const std::vector<mesh::ChunkInfo>& chunks) {
  std::vector<WeightedBox> out;
  out.reserve(chunks.size());
  for (const mesh::ChunkInfo& c : chunks)
    out.push_back({glm::dvec3(c.boundsMin), glm::dvec3(c.boundsMax), double(c.compressedBytes)});
  return out;
}

std::vector<WeightedBox> cellWeights(const mesh::TetMesh& mesh) {
  std::vector<WeightedBox> out(mesh.tets.size());
  for (size_t t = 0; t < mesh.tets.size(); ++t) {
    glm::dvec3 lo(mesh.points[mesh.tets[t][0]]), hi = lo;
    for (int k = 1; k < 4; ++k) {
      lo = glm::min(lo, glm::dvec3(mesh.points[mesh.tets[t][k]]));
      hi = glm::max(hi, glm::dvec3(mesh.points[mesh.tets[t][k]]));
    }
    out[t] = {lo, hi, 1.0};
  }
  return out;
}

PartView meshPartView(const Scene& scene, const TetMeshConstants& constants) {
  const Camera camera = TetView::of(scene, constants).camera;
  PartView view;
  view.orthographic = camera.orthographic;
  view.eye = camera.eye;
  view.direction = camera.viewDirection();
  return view;
}

PixelRect meshPartFootprint(const MeshPartBox& part, const TetMeshConstants& constants, const Scene& scene, int width,
                            int height) {
  const Box& bounds = constants.bounds;
  const double grow = 1e-6 * glm::length(bounds.extent()) + 1e-12;
  Box box;
  for (int a = 0; a < 3; ++a) {
    box.min[a] = std::max(part.lo[size_t(a)], bounds.min[a]) - grow;
    box.max[a] = std::min(part.hi[size_t(a)], bounds.max[a]) + grow;
    if (box.min[a] > box.max[a]) return {};
  }
  return projectedRect(TetView::of(scene, constants).camera, box, width, height);
}

std::vector<int> partsFrontToBack(const MeshPartition& partition, const PartView& view) {
  return kdFrontToBack(partition.nodes, view);
}

bool meets(const MeshPartBox& box, const glm::dvec3& lo, const glm::dvec3& hi) {
  for (int a = 0; a < 3; ++a)
    if (hi[a] < box.lo[size_t(a)] || lo[a] > box.hi[size_t(a)]) return false;
  return true;
}

std::shared_ptr<const TetMeshData> cellsMeeting(const TetMeshData& data, const MeshPartBox& box) {
  const mesh::TetMesh& m = data.mesh;
  // Where each kept cell goes in the part (cells keep their order), -1 for those left out.
  std::vector<int32_t> newCell(m.tets.size(), -1);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, m.tets.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      glm::dvec3 lo(m.points[m.tets[t][0]]), hi = lo;
      for (int k = 1; k < 4; ++k) {
        lo = glm::min(lo, glm::dvec3(m.points[m.tets[t][k]]));
        hi = glm::max(hi, glm::dvec3(m.points[m.tets[t][k]]));
      }
      newCell[t] = meets(box, lo, hi) ? 0 : -1;
    }
  });
  int32_t kept = 0;
  for (int32_t& n : newCell)
    if (n == 0) n = kept++;
  if (kept == 0) return nullptr;
  mesh::TetMesh part;
  mesh::Topology topology;
  part.field = m.field;
  part.tets.reserve(size_t(kept));
  topology.neighbours.reserve(size_t(kept));
  for (size_t t = 0; t < m.tets.size(); ++t) {
    if (newCell[t] < 0) continue;
    part.tets.push_back(m.tets[t]);
    std::array<int32_t, 4> across{};
    for (int f = 0; f < 4; ++f) {
      const int32_t n = data.topology.neighbours[t][size_t(f)];
      across[size_t(f)] = n == mesh::Topology::kBoundary ? n
                          : newCell[size_t(n)] < 0       ? mesh::Topology::kBoundary
                                                         : newCell[size_t(n)];
    }
    topology.neighbours.push_back(across);
  }
  // The points the part uses, renumbered in their order.
  const std::vector<uint32_t> newPoint = mesh::keepUsedPoints(part, m.points, m.scalars);
  for (mesh::Tet& tet : part.tets)
    for (uint32_t& v : tet) v = newPoint[v];
  for (uint32_t t = 0; t < uint32_t(kept); ++t)
    for (uint8_t f = 0; f < 4; ++f)
      if (topology.neighbours[t][f] == mesh::Topology::kBoundary) topology.boundary.push_back({t, f});
  return std::make_shared<const TetMeshData>(std::move(part), std::move(topology),
                                             static_cast<const TetMeshConstants&>(data));
}

}  // namespace voxbrick::render
