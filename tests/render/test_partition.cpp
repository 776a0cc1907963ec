// Sort-last rendering's partition, without GL: the parts' boxes tile the volume on brick boundaries, balanced by
// stored bytes (empty bricks cost nothing), the same on every call, and their front-to-back order agrees with a
// brute-force test of every pair of parts for random cameras, inside the volume and orthographic ones included.
// A mesh's partition (MeshPartition): world-space boxes tiling its box, balanced by the weights given (cells, or a
// store's chunks by stored bytes), the same on every call, in an order the same brute force agrees with; a part's
// cells are those whose extent meets its box, with the faces to cells left out as its boundary.
#include <gtest/gtest.h>

#include <random>

#include "mesh/SyntheticMesh.h"
#include "mesh/Topology.h"
#include "render/RenderFixtures.h"
#include "render/tets/MeshPartition.h"
#include "render/volume/FramePlan.h"
#include "render/volume/Partition.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

uint64_t storedBytes(const store::BrickStore& s, const PartBox& box) {
  const int B = s.brickSize();
  uint64_t bytes = 0;
  for (int k = box.lo[2] / B; k * B < box.hi[2]; ++k)
    for (int j = box.lo[1] / B; j * B < box.hi[1]; ++j)
      for (int i = box.lo[0] / B; i * B < box.hi[0]; ++i)
        bytes += s.record({0, uint32_t(i), uint32_t(j), uint32_t(k)}).compressedSize;
  return bytes;
}

/// Every level-0 voxel of the store in exactly one box, each box's faces on brick boundaries (or the volume's).
void expectTiles(const store::BrickStore& s, const Partition& p, int parts) {
  ASSERT_EQ(p.boxes.size(), size_t(parts));
  ASSERT_EQ(p.bytes.size(), size_t(parts));
  const store::Vec3i dims = s.meta().dims;
  const int B = s.brickSize();
  int64_t voxels = 0;
  for (size_t a = 0; a < p.boxes.size(); ++a) {
    const PartBox& box = p.boxes[a];
    int64_t v = 1;
    for (int c = 0; c < 3; ++c) {
      EXPECT_GE(box.lo[size_t(c)], 0);
      EXPECT_LT(box.lo[size_t(c)], box.hi[size_t(c)]) << "part " << a << " is empty";
      EXPECT_LE(box.hi[size_t(c)], dims[c]);
      EXPECT_EQ(box.lo[size_t(c)] % B, 0) << "part " << a << " starts off a brick boundary";
      EXPECT_TRUE(box.hi[size_t(c)] % B == 0 || box.hi[size_t(c)] == dims[c]) << "part " << a;
      v *= box.hi[size_t(c)] - box.lo[size_t(c)];
    }
    voxels += v;
    EXPECT_EQ(p.bytes[a], storedBytes(s, box)) << "part " << a << ": its bytes are its bricks' stored bytes";
    for (size_t b = a + 1; b < p.boxes.size(); ++b) {
      bool overlap = true;
      for (size_t c = 0; c < 3; ++c)
        overlap = overlap && p.boxes[a].lo[c] < p.boxes[b].hi[c] && p.boxes[b].lo[c] < p.boxes[a].hi[c];
      EXPECT_FALSE(overlap) << "parts " << a << " and " << b << " overlap";
    }
  }
  EXPECT_EQ(voxels, dims.volume()) << "the boxes, disjoint, cover every voxel";
}

/// Whether `a` must be drawn before `b` for `view`: some axis plane separates them with `a` on the eye's side (for
/// an orthographic view: the side the view comes from), none with `b` on it, and the eye is not between them on an
/// axis (in either case no ray meets both). For a grid's voxel boxes and a mesh's world boxes alike.
template <typename Box>
bool mustPrecede(const Box& a, const Box& b, const PartView& view) {
  auto before = [&](const Box& x, const Box& y) {
    for (size_t c = 0; c < 3; ++c) {
      if (x.hi[c] <= y.lo[c] && (view.orthographic ? view.direction[c] > 0 : view.eye[c] < x.hi[c])) return true;
      if (y.hi[c] <= x.lo[c] && (view.orthographic ? view.direction[c] < 0 : view.eye[c] > x.lo[c])) return true;
    }
    return false;
  };
  bool between = false;
  for (size_t c = 0; c < 3 && !view.orthographic; ++c)
    between =
        between || (a.hi[c] < view.eye[c] && view.eye[c] < b.lo[c]) || (b.hi[c] < view.eye[c] && view.eye[c] < a.lo[c]);
  return before(a, b) && !before(b, a) && !between;
}

void expectVisibilityOrder(const Partition& p, const PartView& view, const std::string& what) {
  const std::vector<int> order = partsFrontToBack(p, view);
  ASSERT_EQ(order.size(), p.boxes.size()) << what;
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], int(i)) << what << ": each part once";
  for (size_t i = 0; i < order.size(); ++i)
    for (size_t j = i + 1; j < order.size(); ++j)
      EXPECT_FALSE(mustPrecede(p.boxes[size_t(order[j])], p.boxes[size_t(order[i])], view))
          << what << ": part " << order[j] << " hides part " << order[i] << " but comes after it";
}

TEST(Partition, BoxesTileTheVolumeOnBrickBoundaries) {
  test::ScratchDir dir;
  // 100 x 70 x 40 voxels in bricks of 16: the far bricks are partial.
  const auto s = test::prep("synthetic:blobs,nx=100,ny=70,nz=40", dir / "b", 16);
  const int64_t bricks = s->level(0).bricks.volume();
  for (int parts : {1, 2, 3, 4, 5, 7, 8, 13, int(bricks)}) {
    SCOPED_TRACE("parts " + std::to_string(parts));
    expectTiles(*s, partitionBricks(*s, parts), parts);
  }
  EXPECT_THROW(partitionBricks(*s, 0), std::invalid_argument);
  EXPECT_THROW(partitionBricks(*s, int(bricks) + 1), std::invalid_argument);
}

TEST(Partition, ManyPartsOnFewBricksStillTile) {
  test::ScratchDir dir;
  // 3 x 3 x 1 bricks into 8 parts: halving the parts fits no axis, so the parts follow the bricks.
  const auto s = test::prep("synthetic:blobs,nx=48,ny=48,nz=16", dir / "b", 16);
  for (int parts = 1; parts <= 9; ++parts) {
    SCOPED_TRACE("parts " + std::to_string(parts));
    expectTiles(*s, partitionBricks(*s, parts), parts);
  }
}

TEST(Partition, BalancedByStoredBytesAndEmptyBricksCostNothing) {
  test::ScratchDir dir;
  const auto s = test::prep("synthetic:sparse,n=128", dir / "s", 16);
  const store::Vec3i grid = s->level(0).bricks;
  uint64_t total = 0, largestSlab = 0, largestBrick = 0;
  int64_t empty = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int64_t at = 0; at < grid[axis]; ++at) {
      uint64_t slab = 0;
      for (int64_t k = 0; k < grid.z; ++k)
        for (int64_t j = 0; j < grid.y; ++j)
          for (int64_t i = 0; i < grid.x; ++i)
            if ((axis == 0 ? i : axis == 1 ? j : k) == at) {
              const uint64_t b = s->record({0, uint32_t(i), uint32_t(j), uint32_t(k)}).compressedSize;
              slab += b;
              largestBrick = std::max(largestBrick, b);
              if (axis == 0) total += b, empty += b == 0;
            }
      largestSlab = std::max(largestSlab, slab);
    }
  ASSERT_GT(empty, 0) << "a sparse field has empty bricks";
  ASSERT_GT(total, 0u);

  // Two parts: the split is within one brick's bytes of the best brick boundary on its axis.
  const Partition two = partitionBricks(*s, 2);
  const Partition::Node& root = two.nodes.at(0);
  ASSERT_GE(root.axis, 0);
  const int B = s->brickSize();
  for (int64_t at = 1; at < grid[root.axis]; ++at) {
    PartBox lower{{0, 0, 0}, {int(s->meta().dims.x), int(s->meta().dims.y), int(s->meta().dims.z)}};
    lower.hi[size_t(root.axis)] = int(at * B);
    const double error = std::abs(double(storedBytes(*s, lower)) - 0.5 * double(total));
    EXPECT_LE(std::abs(double(two.bytes[0]) - 0.5 * double(total)), error + double(largestBrick))
        << "a split at brick " << at << " is better";
  }
  // More parts: each within one slab of bricks of its share per level of the tree.
  for (int parts : {2, 3, 4, 5, 8}) {
    const Partition p = partitionBricks(*s, parts);
    uint64_t sum = 0;
    for (uint64_t b : p.bytes) sum += b;
    EXPECT_EQ(sum, total) << parts << " parts: the bytes of every brick, once";
    const int depth = int(std::ceil(std::log2(double(parts))));
    for (size_t a = 0; a < p.bytes.size(); ++a)
      EXPECT_LE(std::abs(double(p.bytes[a]) - double(total) / parts), depth * double(largestSlab))
          << parts << " parts: part " << a;
  }
  // The empty half of a volume costs nothing: a field with bytes only at low x puts most parts' boxes there.
  const store::Vec3i n{64, 16, 16};
  std::vector<float> values(size_t(n.volume()), 0.0f);
  for (int64_t z = 0; z < n.z; ++z)
    for (int64_t y = 0; y < n.y; ++y)
      for (int64_t x = 0; x < 16; ++x) values[size_t(x + n.x * (y + n.y * z))] = float((x * 7 + y * 3 + z) % 11);
  const auto lopsided = test::prepArray(n, store::ValueType::F32, values, dir / "l", 8);
  const Partition p = partitionBricks(*lopsided, 2);
  // Half the stored bytes lie in the first 8 voxels along x; a split one coarse brick on (16) is allowed by the
  // preference for coarse boundaries, but a split by volume (32) or anything past the data is not.
  EXPECT_EQ(p.nodes.at(0).axis, 0);
  EXPECT_GE(p.boxes[0].hi[0], 8);
  EXPECT_LE(p.boxes[0].hi[0], 16) << "the split lies where the stored bytes are, not half way along x";
  EXPECT_EQ(p.bytes[0] + p.bytes[1], storedBytes(*lopsided, p.boxes[0]) + storedBytes(*lopsided, p.boxes[1]));
}

TEST(Partition, SplitsOnCoarseBrickBoundariesWhenTheBalanceAllows) {
  test::ScratchDir dir;
  // Six alike bricks along x: the best balance cuts at brick 3, through a level-1 brick; one brick's bytes away,
  // bricks 2 and 4 lie on coarser bricks' boundaries (4 on level 2's).
  const store::Vec3i n{96, 16, 16};
  std::vector<float> values(size_t(n.volume()));
  for (int64_t z = 0; z < n.z; ++z)
    for (int64_t y = 0; y < n.y; ++y)
      for (int64_t x = 0; x < n.x; ++x) values[size_t(x + n.x * (y + n.y * z))] = float(1 + (x % 16 + y + z) % 5);
  const auto s = test::prepArray(n, store::ValueType::F32, values, dir / "a", 16);
  ASSERT_GE(s->levelCount(), 3);
  const Partition p = partitionBricks(*s, 2);
  EXPECT_EQ(p.boxes[0].hi[0] % 32, 0) << "split at voxel " << p.boxes[0].hi[0] << ": on a level-0 brick's face only";
  EXPECT_LE(std::abs(double(p.bytes[0]) - double(p.bytes[1])), 2.5 * double(std::max(p.bytes[0], p.bytes[1])) / 3)
      << "still within about a brick of the balance";
}

TEST(Partition, Deterministic) {
  test::ScratchDir dir;
  const auto s = test::prep("synthetic:sparse,n=96", dir / "s", 16);
  const auto again = store::BrickStore::open(dir / "s");
  for (int parts = 1; parts <= 6; ++parts) {
    const Partition a = partitionBricks(*s, parts), b = partitionBricks(*again, parts);
    EXPECT_EQ(a.boxes, b.boxes);
    EXPECT_EQ(a.bytes, b.bytes);
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    for (size_t i = 0; i < a.nodes.size(); ++i) {
      EXPECT_EQ(a.nodes[i].axis, b.nodes[i].axis);
      EXPECT_EQ(a.nodes[i].position, b.nodes[i].position);
      EXPECT_EQ(a.nodes[i].part, b.nodes[i].part);
    }
  }
}

TEST(Partition, FrontToBackAgreesWithEveryPairOfParts) {
  test::ScratchDir dir;
  const auto s = test::prep("synthetic:blobs,nx=96,ny=80,nz=64", dir / "b", 16);
  const store::Vec3i dims = s->meta().dims;
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int parts : {2, 3, 5, 8, 16}) {
    const Partition p = partitionBricks(*s, parts);
    for (int c = 0; c < 40; ++c) {
      PartView view;
      view.orthographic = c % 4 == 3;
      // Eyes outside (up to twice the volume away) and inside the volume.
      const double reach = c % 4 == 2 ? 1.0 : 3.0, offset = c % 4 == 2 ? 0.0 : -1.0;
      for (int a = 0; a < 3; ++a) view.eye[a] = (offset + reach * unit(random)) * double(dims[a]);
      view.direction = glm::dvec3(unit(random), unit(random), unit(random)) - 0.5;
      expectVisibilityOrder(p, view, std::to_string(parts) + " parts, camera " + std::to_string(c));
    }
  }
}

TEST(Partition, ViewFollowsTheRenderersCamera) {
  test::ScratchDir dir;
  const auto s = test::prep("synthetic:blobs,nx=64,ny=32,nz=32", dir / "b", 16, {});
  const store::StoreMeta& meta = s->meta();
  for (const auto& [name, camera] : test::marchCameras(true)) {
    Scene scene;
    scene.camera = camera;
    const FramePlan plan = planFrame(scene, *s, kTransferTableTexels);
    const PartView view = partView(meta, scene);
    EXPECT_EQ(view.orthographic, plan.camera.orthographic) << name;
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(view.eye[a], (plan.camera.eye[a] - plan.volume.min[a]) / meta.spacing[a], 1e-9) << name;
      EXPECT_GT(view.direction[a] * plan.camera.viewDirection()[a], -1e-12) << name << ": the same signs";
    }
    if (name == "inside")
      for (int a = 0; a < 3; ++a) {
        EXPECT_GT(view.eye[a], 0.0) << name;
        EXPECT_LT(view.eye[a], double(meta.dims[a])) << name;
      }
  }
}

// A mesh's partition -------------------------------------------------------------------------------------------------

/// A mesh part's box as a closed world box clipped to `bounds` (its faces on the mesh's box are pushed out).
Box clippedPart(const MeshPartBox& part, const Box& bounds) {
  Box b;
  for (int a = 0; a < 3; ++a) {
    b.min[a] = std::max(part.lo[size_t(a)], bounds.min[a]);
    b.max[a] = std::min(part.hi[size_t(a)], bounds.max[a]);
  }
  return b;
}

/// The mesh's box tiled: every part's box, clipped to it, has volume, none overlaps another, and they add up to it;
/// faces on the mesh's box lie beyond it.
void expectMeshTiles(const MeshPartition& p, const Box& bounds, int parts) {
  ASSERT_EQ(p.boxes.size(), size_t(parts));
  ASSERT_EQ(p.weights.size(), size_t(parts));
  const glm::dvec3 e = bounds.extent();
  double volume = 0;
  for (size_t a = 0; a < p.boxes.size(); ++a) {
    const Box box = clippedPart(p.boxes[a], bounds);
    const glm::dvec3 size = box.max - box.min;
    EXPECT_GT(size.x * size.y * size.z, 0.0) << "part " << a << " is empty";
    volume += size.x * size.y * size.z;
    for (int c = 0; c < 3; ++c) {
      if (p.boxes[a].lo[size_t(c)] <= bounds.min[c]) {
        EXPECT_LT(p.boxes[a].lo[size_t(c)], bounds.min[c] - 0.5 * e[c]);
      }
      if (p.boxes[a].hi[size_t(c)] >= bounds.max[c]) {
        EXPECT_GT(p.boxes[a].hi[size_t(c)], bounds.max[c] + 0.5 * e[c]);
      }
    }
    for (size_t b = a + 1; b < p.boxes.size(); ++b) {
      bool overlap = true;
      for (size_t c = 0; c < 3; ++c)
        overlap = overlap && p.boxes[a].lo[c] < p.boxes[b].hi[c] && p.boxes[b].lo[c] < p.boxes[a].hi[c];
      EXPECT_FALSE(overlap) << "parts " << a << " and " << b << " overlap";
    }
  }
  EXPECT_NEAR(volume, e.x * e.y * e.z, 1e-9 * e.x * e.y * e.z) << "the boxes, disjoint, cover the mesh's box";
}

// A part's footprint: every pixel whose ray (the reference's pixel rays) meets the box lies in projectedRect, for
// random boxes and cameras (perspective from outside, orthographic); a box with a corner behind the eye gives the
// whole frame; a box off to the side gives nothing; and the rectangle is tight (within its margin and a pixel of the
// rays' own extent).
TEST(Footprint, EveryPixelWhoseRayMeetsTheBoxLiesInIt) {
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const int width = 80, height = 60;
  int checked = 0;
  for (int trial = 0; trial < 60; ++trial) {
    Box box;
    for (int a = 0; a < 3; ++a) {
      const double c = 0.5 * unit(random), h = 0.05 + 0.3 * std::abs(unit(random));
      box.min[a] = c - h, box.max[a] = c + h;
    }
    Camera camera = Camera::orbit(180 * unit(random), 80 * unit(random), 2.5, Box{{-1, -1, -1}, {1, 1, 1}});
    camera.orthographic = trial % 3 == 0;
    camera.fovYDegrees = 30 + 20 * std::abs(unit(random));
    const PixelRect rect = projectedRect(camera, box, width, height, 0);
    const RayBasis basis = RayBasis::of(camera, double(width) / height, 0.01);
    PixelRect hit{width, height, 0, 0};
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        glm::dvec3 origin, direction;
        double tNear = 0;
        basis.pixelRay(x, y, width, height, origin, direction, tNear);
        double t0 = 0, t1 = 1e30;
        for (int a = 0; a < 3; ++a) {
          const double inv = 1.0 / direction[a];
          double ta = (box.min[a] - origin[a]) * inv, tb = (box.max[a] - origin[a]) * inv;
          if (ta > tb) std::swap(ta, tb);
          t0 = std::max(t0, ta), t1 = std::min(t1, tb);
        }
        if (t0 > t1) continue;
        ++checked;
        EXPECT_TRUE(x >= rect.x0 && x < rect.x1 && y >= rect.y0 && y < rect.y1)
            << "trial " << trial << ": pixel (" << x << ", " << y << ") meets the box outside [" << rect.x0 << ", "
            << rect.x1 << ") x [" << rect.y0 << ", " << rect.y1 << ")";
        hit.x0 = std::min(hit.x0, x), hit.y0 = std::min(hit.y0, y);
        hit.x1 = std::max(hit.x1, x + 1), hit.y1 = std::max(hit.y1, y + 1);
      }
    }
    if (hit.empty()) continue;
    EXPECT_LE(rect.pixels(), (long long)(hit.x1 - hit.x0 + 2) * (hit.y1 - hit.y0 + 2)) << "trial " << trial << ": loose";
  }
  EXPECT_GT(checked, 1000);
  // A corner behind the eye: the whole frame. Off to the side: nothing. No pixels: nothing.
  const Camera camera = Camera::orbit(0, 0, 2.5, Box{{-1, -1, -1}, {1, 1, 1}});
  const glm::dvec3 eye = camera.eye;
  EXPECT_EQ(projectedRect(camera, Box{eye - 0.1, eye + 0.1}, width, height), (PixelRect{0, 0, width, height}));
  const glm::dvec3 side = glm::cross(camera.viewDirection(), camera.upVector());
  EXPECT_TRUE(projectedRect(camera, Box{side * 40.0 - 0.1, side * 40.0 + 0.1}, width, height).empty());
  EXPECT_TRUE(projectedRect(camera, Box{{-0.1, -0.1, -0.1}, {0.1, 0.1, 0.1}}, 0, height).empty());
}

TEST(MeshPartition, BoxesTileTheMeshBalancedByCells) {
  const mesh::TetMesh m = mesh::syntheticMesh("ball,n=24");
  const auto [lo, hi] = m.bounds();
  const Box bounds{glm::dvec3(lo), glm::dvec3(hi)};
  const std::vector<WeightedBox> cells = cellWeights(m);
  ASSERT_EQ(cells.size(), m.tets.size());
  for (int parts : {1, 2, 3, 4, 5, 7, 8, 16}) {
    SCOPED_TRACE("parts " + std::to_string(parts));
    const MeshPartition p = partitionMesh(cells, bounds, parts);
    expectMeshTiles(p, bounds, parts);
    double sum = 0;
    for (double w : p.weights) sum += w;
    EXPECT_NEAR(sum, double(m.tets.size()), 1e-6 * double(m.tets.size())) << "every cell's weight, once";
    // Each part within 2% of its share as weighed (each cell spread over its box: the bisection itself is exact),
    // and the cells whose centroid lies in it within 15% of the share (cells are not spread, but small).
    const double share = double(m.tets.size()) / parts;
    for (size_t a = 0; a < p.weights.size(); ++a) {
      EXPECT_NEAR(p.weights[a], share, 0.02 * share) << "part " << a;
      size_t centroids = 0;
      for (const WeightedBox& cell : cells) {
        const glm::dvec3 c = 0.5 * (cell.lo + cell.hi);
        bool in = true;
        for (size_t k = 0; k < 3; ++k) in = in && c[int(k)] >= p.boxes[a].lo[k] && c[int(k)] < p.boxes[a].hi[k];
        centroids += in ? 1 : 0;
      }
      EXPECT_NEAR(double(centroids), share, 0.15 * share) << "part " << a;
    }
  }
  EXPECT_THROW(partitionMesh(cells, bounds, 0), std::invalid_argument);
}

TEST(MeshPartition, WeightsDecideWhereThePlanesGo) {
  // Weight only in the lowest eighth along x: two parts split inside it, not half way along the box.
  const Box bounds{glm::dvec3(0), glm::dvec3(8, 1, 1)};
  std::vector<WeightedBox> items{{glm::dvec3(0, 0, 0), glm::dvec3(1, 1, 1), 100.0},
                                 {glm::dvec3(1, 0, 0), glm::dvec3(8, 1, 1), 0.0}};
  const MeshPartition two = partitionMesh(items, bounds, 2);
  ASSERT_EQ(two.nodes.at(0).axis, 0);
  EXPECT_NEAR(two.nodes[0].position, 0.5, 1e-9);
  EXPECT_NEAR(two.weights[0], 50.0, 1e-6);
  EXPECT_NEAR(two.weights[1], 50.0, 1e-6);
  // A region that weighs nothing is cut in the middle.
  const MeshPartition empty = partitionMesh({}, bounds, 2);
  EXPECT_NEAR(empty.nodes.at(0).position, 4.0, 1e-9);
  // Three parts: the lower side takes one, its third of the weight.
  const MeshPartition three = partitionMesh(items, bounds, 3);
  EXPECT_NEAR(three.nodes.at(0).position, 1.0 / 3, 1e-9);
  expectMeshTiles(three, bounds, 3);
}

TEST(MeshPartition, DeterministicAndOrderedFrontToBack) {
  const mesh::TetMesh m = mesh::syntheticMesh("box,n=8");
  const auto [lo, hi] = m.bounds();
  const Box bounds{glm::dvec3(lo), glm::dvec3(hi)};
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int parts : {2, 3, 5, 8, 13}) {
    const MeshPartition p = partitionMesh(cellWeights(m), bounds, parts);
    const MeshPartition again = partitionMesh(cellWeights(m), bounds, parts);
    EXPECT_EQ(p.boxes, again.boxes);
    EXPECT_EQ(p.weights, again.weights);
    for (int c = 0; c < 40; ++c) {
      PartView view;
      view.orthographic = c % 4 == 3;
      // Eyes outside (up to twice the box away) and inside it.
      const double reach = c % 4 == 2 ? 1.0 : 3.0, offset = c % 4 == 2 ? 0.0 : -1.0;
      for (int a = 0; a < 3; ++a) view.eye[a] = bounds.min[a] + (offset + reach * unit(random)) * bounds.extent()[a];
      view.direction = glm::dvec3(unit(random), unit(random), unit(random)) - 0.5;
      const std::vector<int> order = partsFrontToBack(p, view);
      ASSERT_EQ(order.size(), size_t(parts));
      std::vector<int> sorted = order;
      std::sort(sorted.begin(), sorted.end());
      for (size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], int(i)) << "each part once";
      for (size_t i = 0; i < order.size(); ++i)
        for (size_t j = i + 1; j < order.size(); ++j)
          EXPECT_FALSE(mustPrecede(p.boxes[size_t(order[j])], p.boxes[size_t(order[i])], view))
              << parts << " parts, camera " << c << ": part " << order[j] << " hides part " << order[i]
              << " but comes after it";
    }
  }
}

TEST(MeshPartition, APartsCellsAreThoseMeetingItsBox) {
  mesh::TetMesh m = mesh::syntheticMesh("box,n=6");
  mesh::Topology t = mesh::buildTopology(m);
  const TetMeshData whole(std::move(m), std::move(t));
  const MeshPartition p = partitionMesh(cellWeights(whole.mesh), whole.bounds, 3);
  size_t total = 0;
  for (const MeshPartBox& box : p.boxes) {
    const std::shared_ptr<const TetMeshData> part = cellsMeeting(whole, box);
    ASSERT_TRUE(part);
    // Exactly the cells whose box meets the part's, in their order.
    size_t expected = 0;
    for (const WeightedBox& cell : cellWeights(whole.mesh)) expected += meets(box, cell.lo, cell.hi) ? 1 : 0;
    EXPECT_EQ(part->mesh.tets.size(), expected);
    EXPECT_LT(part->mesh.tets.size(), whole.mesh.tets.size());
    total += part->mesh.tets.size();
    for (const WeightedBox& cell : cellWeights(part->mesh)) EXPECT_TRUE(meets(box, cell.lo, cell.hi));
    // The whole mesh's constants; a topology whose neighbours agree both ways, its boundary every face without one.
    EXPECT_EQ(part->bounds.min, whole.bounds.min);
    EXPECT_EQ(part->tetCount, whole.tetCount);
    size_t boundary = 0;
    for (size_t c = 0; c < part->topology.neighbours.size(); ++c)
      for (size_t f = 0; f < 4; ++f) {
        const int32_t n = part->topology.neighbours[c][f];
        if (n == mesh::Topology::kBoundary) {
          ++boundary;
          continue;
        }
        const auto& back = part->topology.neighbours[size_t(n)];
        EXPECT_NE(std::find(back.begin(), back.end(), int32_t(c)), back.end());
      }
    EXPECT_EQ(part->topology.boundary.size(), boundary);
    EXPECT_GT(boundary, whole.topology.boundary.size() / 3) << "the cut faces are the part's boundary too";
  }
  EXPECT_GT(total, whole.mesh.tets.size()) << "cells straddling a cut are in both parts";
  // A box off the mesh holds no cell.
  EXPECT_FALSE(cellsMeeting(whole, MeshPartBox{{5, 5, 5}, {6, 6, 6}}));
}

}  // namespace
}  // namespace voxbrick::render
