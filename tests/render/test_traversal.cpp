// Octree traversal: completeness, front-to-back order, empty-space skipping, frustum culling and statistics; and
// the same inside a brick for sub-blocks.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

#include "brickstore/read/MinMaxOctree.h"
#include "render/core/Camera.h"
#include "render/core/RenderErrors.h"
#include "render/core/TransferFunction.h"
#include "render/volume/SubBlocks.h"
#include "render/volume/Traversal.h"

namespace voxbrick::render {
namespace {

using store::MinMaxOctree;
using store::Vec3i;

constexpr int kB = 8;
// 5 x 4 x 3 bricks of 8 voxels, the last brick along x and z partial; anisotropic spacing.
const Vec3i kDims{37, 32, 17};
const store::Vec3d kTraversalSpacing{1.0, 0.5, 2.0};

struct Grid {
  Vec3i bricks{5, 4, 3};
  std::vector<MinMaxOctree::Range> ranges;
  MinMaxOctree octree;
  explicit Grid(unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0, 1);
    for (int64_t n = 0; n < bricks.volume(); ++n) {
      float a = unit(rng), b = unit(rng);
      ranges.push_back({std::min(a, b), std::max(a, b)});
    }
    octree = MinMaxOctree(bricks, ranges);
  }
  int64_t index(const store::BrickKey& k) const { return k.i + bricks.x * (k.j + bricks.y * int64_t{k.k}); }
};

const TraversalOptions kEverything{false, false, {}, {}};

Camera lookingFrom(const glm::dvec3& eye, bool ortho = false, const glm::dvec3& center = {0.1, 0.2, 0.3}) {
  Camera camera;
  camera.eye = eye;
  camera.center = center;
  camera.orthographic = ortho;
  return camera;
}

// +1 if a must be drawn before b, -1 if b before a, 0 if neither can occlude the other. Along each axis on which
// the boxes are separated, the one on the eye's side (perspective) or first along the view direction (orthographic)
// must come first; an axis with the eye between the boxes, or axes that disagree, mean no ray meets both.
int requiredOrder(const Box& a, const Box& b, const Camera& camera) {
  glm::dvec3 d = camera.viewDirection();
  int order = 0;
  for (int ax = 0; ax < 3; ++ax) {
    int s;
    if (a.max[ax] <= b.min[ax] || b.max[ax] <= a.min[ax]) {
      bool aLow = a.max[ax] <= b.min[ax];
      double lowFace = aLow ? a.max[ax] : b.max[ax], highFace = aLow ? b.min[ax] : a.min[ax];
      int lowFirst;
      if (camera.orthographic)
        lowFirst = d[ax] > 0 ? 1 : (d[ax] < 0 ? -1 : 0);
      else
        lowFirst = camera.eye[ax] < lowFace ? 1 : (camera.eye[ax] > highFace ? -1 : 0);
      if (lowFirst == 0) return 0;
      s = aLow ? lowFirst : -lowFirst;
    } else {
      continue;
    }
    if (order == 0)
      order = s;
    else if (order != s)
      return 0;
  }
  return order;
}

// Checks the separating-plane property for every pair of drawn bricks; returns how many pairs were constrained.
int checkVisibilityOrder(const std::vector<BrickDraw>& bricks, const Camera& camera) {
  int constrained = 0;
  for (size_t p = 0; p < bricks.size(); ++p)
    for (size_t q = p + 1; q < bricks.size(); ++q) {
      int order = requiredOrder(bricks[p].box, bricks[q].box, camera);
      if (order != 0) ++constrained;
      EXPECT_GE(order, 0) << "brick " << store::toString(bricks[q].key) << " must come before "
                          << store::toString(bricks[p].key);
    }
  return constrained;
}

std::map<std::tuple<uint32_t, uint32_t, uint32_t>, int> countKeys(const std::vector<BrickDraw>& bricks) {
  std::map<std::tuple<uint32_t, uint32_t, uint32_t>, int> seen;
  for (const BrickDraw& b : bricks) {
    EXPECT_EQ(b.key.level, 0u);
    ++seen[{b.key.i, b.key.j, b.key.k}];
  }
  return seen;
}

void expectStatsAddUp(const TraversalResult& r, const Grid& grid) {
  EXPECT_EQ(r.stats.bricksDrawn, static_cast<int64_t>(r.bricks.size()));
  EXPECT_EQ(r.stats.bricksDrawn + r.stats.bricksSkippedEmpty + r.stats.bricksCulled + r.stats.bricksOutsidePart,
            grid.bricks.volume());
}

TEST(TraversalBricks, WithNothingSkippedEveryBrickAppearsOnceWithItsBox) {
  Grid grid(1);
  OctreeTraversal traversal(grid.octree, kDims, kB, kTraversalSpacing);
  TraversalResult r = traversal.run(lookingFrom({100, 50, -80}), Frustum{}, {}, kEverything);
  auto seen = countKeys(r.bricks);
  EXPECT_EQ(static_cast<int64_t>(seen.size()), grid.bricks.volume());
  for (const auto& [key, count] : seen) EXPECT_EQ(count, 1);
  expectStatsAddUp(r, grid);
  EXPECT_EQ(r.stats.bricksDrawn, 60);
  double volume = 0;
  for (const BrickDraw& b : r.bricks) {
    glm::dvec3 e = b.box.extent();
    volume += e.x * e.y * e.z;
    EXPECT_EQ(b.box.min, traversal.brickBox(b.key.i, b.key.j, b.key.k).min);
    EXPECT_EQ(b.box.max, traversal.brickBox(b.key.i, b.key.j, b.key.k).max);
  }
  glm::dvec3 whole = traversal.volume().extent();
  EXPECT_NEAR(volume, whole.x * whole.y * whole.z, 1e-9);
  // The last brick along x holds voxels [32, 37): world x from (32 - 18.5) * 1 to (37 - 18.5) * 1.
  Box last = traversal.brickBox(4, 3, 2);
  EXPECT_EQ(last.min, glm::dvec3(13.5, (24 - 16) * 0.5, (16 - 8.5) * 2.0));
  EXPECT_EQ(last.max, glm::dvec3(18.5, 8.0, 17.0));
  EXPECT_EQ(traversal.brickBox(0, 0, 0).min, traversal.volume().min);
}

TEST(TraversalBricks, NodeBoxesAreTheUnionOfTheirBricks) {
  Grid grid(2);
  OctreeTraversal traversal(grid.octree, kDims, kB, kTraversalSpacing);
  for (int d = 0; d <= grid.octree.depth(); ++d) {
    Vec3i n = grid.octree.nodesAt(d);
    for (int64_t k = 0; k < n.z; ++k)
      for (int64_t j = 0; j < n.y; ++j)
        for (int64_t i = 0; i < n.x; ++i) {
          Vec3i lo, hi;
          grid.octree.brickSpan(d, i, j, k, lo, hi);
          Box u{glm::dvec3(1e300), glm::dvec3(-1e300)};
          for (int64_t z = lo.z; z < hi.z; ++z)
            for (int64_t y = lo.y; y < hi.y; ++y)
              for (int64_t x = lo.x; x < hi.x; ++x) {
                Box b = traversal.brickBox(x, y, z);
                u.min = glm::min(u.min, b.min);
                u.max = glm::max(u.max, b.max);
              }
          Box node = traversal.nodeBox(d, i, j, k);
          EXPECT_EQ(node.min, u.min);
          EXPECT_EQ(node.max, u.max);
        }
  }
  EXPECT_EQ(traversal.nodeBox(0, 0, 0, 0).max, traversal.volume().max);
}

TEST(TraversalOrder, PerspectiveIsFrontToBackForRandomEyes) {
  Grid grid(3);
  OctreeTraversal traversal(grid.octree, kDims, kB, kTraversalSpacing);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> coord(-40, 40);
  int constrained = 0;
  for (int trial = 0; trial < 120; ++trial) {
    glm::dvec3 eye{coord(rng), coord(rng), coord(rng)};
    // Some eyes exactly on brick faces and split planes, where ties must still be ordered correctly.
    if (trial % 4 == 1) eye.x = traversal.brickBox(2, 0, 0).min.x;
    if (trial % 4 == 2) eye.y = traversal.brickBox(0, 2, 0).min.y;
    if (trial % 4 == 3) eye = traversal.brickBox(1, 1, 1).max;
    if (trial % 10 == 0) eye *= 0.1;  // inside the volume
    Camera camera = lookingFrom(eye, false, eye + glm::dvec3(0.3, -0.2, 1));
    TraversalResult r = traversal.run(camera, Frustum{}, {}, kEverything);
    ASSERT_EQ(r.bricks.size(), 60u);
    constrained += checkVisibilityOrder(r.bricks, camera);
  }
  EXPECT_GT(constrained, 120 * 200);
}

TEST(TraversalOrder, OrthographicFollowsTheViewDirection) {
  Grid grid(4);
  OctreeTraversal traversal(grid.octree, kDims, kB, kTraversalSpacing);
  std::mt19937 rng(12);
  std::normal_distribution<double> gauss;
  std::vector<glm::dvec3> directions = {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}, {1, 1, 0}, {-1, 0, -1}};
  for (int i = 0; i < 40; ++i) directions.push_back({gauss(rng), gauss(rng), gauss(rng)});
  int constrained = 0;
  for (const glm::dvec3& direction : directions) {
    // The eye sits inside the volume on purpose: for orthographic views only the direction decides the order.
    Camera camera = lookingFrom({1, 2, 3}, true, glm::dvec3(1, 2, 3) + direction);
    TraversalResult r = traversal.run(camera, Frustum{}, {}, kEverything);
    ASSERT_EQ(r.bricks.size(), 60u);
    constrained += checkVisibilityOrder(r.bricks, camera);
  }
  EXPECT_GT(constrained, 40 * 500);
}

TEST(TraversalSkip, SkipsExactlyTheRejectedBricksAndCountsThem) {
  Grid grid(5);
  OctreeTraversal traversal(grid.octree, kDims, kB, kTraversalSpacing);
  for (float threshold : {0.0f, 0.3f, 0.6f, 0.9f, 1.1f}) {
    auto contributes = [threshold](float, float max) { return max > threshold; };
    TraversalResult r = traversal.run(lookingFrom({-60, 10, 70}), Frustum{}, contributes, {true, false, {}, {}});
    auto seen = countKeys(r.bricks);
    int64_t expected = 0;
    for (uint32_t k = 0; k < 3; ++k)
      for (uint32_t j = 0; j < 4; ++j)
        for (uint32_t i = 0; i < 5; ++i) {
          bool visible = grid.ranges[static_cast<size_t>(grid.index({0, i, j, k}))].max > threshold;
          expected += visible;
          EXPECT_EQ(seen.count({i, j, k}), visible ? 1u : 0u);
        }
    EXPECT_EQ(r.stats.bricksDrawn, expected);
    EXPECT_EQ(r.stats.bricksSkippedEmpty, 60 - expected);
    EXPECT_EQ(r.stats.bricksCulled, 0);
    expectStatsAddUp(r, grid);
  }
}

TEST(TraversalPart, WalksOnlyThePartsBricksInTheSameOrderAndLeavesTheRestUnvisited) {
  Grid grid(7);
  OctreeTraversal traversal(grid.octree, kDims, kB, kTraversalSpacing);
  const Camera camera = lookingFrom({-60, 10, 70});
  const TraversalResult whole = traversal.run(camera, Frustum{}, {}, kEverything);
  for (const auto& [lo, hi] : {std::pair{Vec3i{0, 0, 0}, Vec3i{2, 4, 3}}, std::pair{Vec3i{3, 1, 2}, Vec3i{5, 3, 3}},
                               std::pair{Vec3i{4, 3, 2}, Vec3i{5, 4, 3}}}) {
    TraversalOptions options = kEverything;
    options.partBricks = std::array<Vec3i, 2>{lo, hi};
    const TraversalResult part = traversal.run(camera, Frustum{}, {}, options);
    std::vector<std::tuple<uint32_t, uint32_t, uint32_t>> expected, got;
    for (const BrickDraw& b : whole.bricks)
      if (const Vec3i at{b.key.i, b.key.j, b.key.k};
          at.x >= lo.x && at.x < hi.x && at.y >= lo.y && at.y < hi.y && at.z >= lo.z && at.z < hi.z)
        expected.emplace_back(b.key.i, b.key.j, b.key.k);
    for (const BrickDraw& b : part.bricks) got.emplace_back(b.key.i, b.key.j, b.key.k);
    EXPECT_EQ(got, expected);  // the same bricks, front to back as the whole walk has them
    const int64_t inside = (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z);
    EXPECT_EQ(part.stats.bricksDrawn, inside);
    EXPECT_EQ(part.stats.bricksOutsidePart, grid.bricks.volume() - inside);
    EXPECT_LT(part.stats.nodesVisited, whole.stats.nodesVisited);  // the nodes outside are not walked into
    expectStatsAddUp(part, grid);
  }
}

TEST(TraversalSkip, AnEmptyRootSkipsTheWholeGridInOneVisit) {
  Vec3i bricks{64, 64, 64};
  std::vector<MinMaxOctree::Range> ranges(static_cast<size_t>(bricks.volume()), {0.0f, 0.01f});
  ranges[12345] = {0.0f, 0.9f};
  MinMaxOctree octree(bricks, ranges);
  OctreeTraversal traversal(octree, {64 * 16, 64 * 16, 64 * 16}, 16, {1, 1, 1});
  TransferFunction tf({{0, {0, 0, 0, 0}}, {0.02, {0, 0, 0, 0}}, {0.02, {1, 1, 1, 0.3}}});
  auto contributes = [&tf](float min, float max) { return tf.contributes(min, max); };
  TraversalResult r = traversal.run(lookingFrom({0, 0, 5000}), Frustum{}, contributes, {true, false, {}, {}});
  ASSERT_EQ(r.bricks.size(), 1u);
  EXPECT_EQ(r.bricks[0].key, (store::BrickKey{0, 12345 % 64, (12345 / 64) % 64, 12345 / 4096}));
  EXPECT_EQ(r.stats.bricksSkippedEmpty, bricks.volume() - 1);
  // One path from the root to the brick, plus the siblings skipped along it.
  EXPECT_EQ(r.stats.nodesVisited, 1 + 8 * octree.depth());
  ranges[12345] = {0.0f, 0.01f};
  MinMaxOctree empty(bricks, ranges);
  TraversalResult none = OctreeTraversal(empty, {1024, 1024, 1024}, 16, {1, 1, 1})
                             .run(lookingFrom({0, 0, 5000}), Frustum{}, contributes, {true, false, {}, {}});
  EXPECT_TRUE(none.bricks.empty());
  EXPECT_EQ(none.stats.nodesVisited, 1);
  EXPECT_EQ(none.stats.bricksSkippedEmpty, bricks.volume());
}

TEST(TraversalCull, RemovesExactlyTheBricksOutsideTheFrustumAndNoVisibleOne) {
  Grid grid(6);
  OctreeTraversal traversal(grid.octree, kDims, kB, kTraversalSpacing);
  const Box& volume = traversal.volume();
  struct View {
    Camera camera;
    double aspect;
  };
  std::vector<View> views;
  Camera narrow = Camera::orbit(35, 25, 1.6, volume);
  narrow.center = traversal.brickBox(4, 3, 2).center();
  narrow.fovYDegrees = 12;
  views.push_back({narrow, 1.0});
  Camera inside = lookingFrom({2, 1, 3}, false, {30, 1, 3});
  inside.fovYDegrees = 60;
  views.push_back({inside, 1.5});
  Camera ortho = narrow;
  ortho.orthographic = true;
  ortho.fovYDegrees = 5;
  views.push_back({ortho, 0.5});
  for (const View& v : views) {
    double near = 0, far = 0;
    v.camera.clipRange(volume, near, far);
    glm::dmat4 vp = v.camera.projection(v.aspect, near, far) * v.camera.view();
    Frustum frustum = Frustum::fromMatrix(vp);
    TraversalResult r = traversal.run(v.camera, frustum, {}, {false, true, {}, {}});
    auto seen = countKeys(r.bricks);
    for (uint32_t k = 0; k < 3; ++k)
      for (uint32_t j = 0; j < 4; ++j)
        for (uint32_t i = 0; i < 5; ++i) {
          Box box = traversal.brickBox(i, j, k);
          bool drawn = seen.count({i, j, k}) == 1;
          EXPECT_EQ(drawn, frustum.intersects(box));
          // Brute force: a brick with any sample point inside the clip volume must be drawn.
          for (int s = 0; s < 125 && !drawn; ++s) {
            glm::dvec3 t{(s % 5) / 4.0, (s / 5 % 5) / 4.0, (s / 25) / 4.0};
            glm::dvec4 c = vp * glm::dvec4(box.min + t * box.extent(), 1.0);
            bool inClip = std::abs(c.x) < c.w && std::abs(c.y) < c.w && std::abs(c.z) < c.w;
            EXPECT_FALSE(inClip) << "brick " << i << "," << j << "," << k << " was culled but is visible";
          }
        }
    EXPECT_GT(r.stats.bricksCulled, 0);
    EXPECT_GT(r.stats.bricksDrawn, 0);
    EXPECT_EQ(r.stats.bricksSkippedEmpty, 0);
    expectStatsAddUp(r, grid);
    checkVisibilityOrder(r.bricks, v.camera);
  }
}

TEST(TraversalCull, SkippingAndCullingTogetherAddUp) {
  Grid grid(7);
  OctreeTraversal traversal(grid.octree, kDims, kB, kTraversalSpacing);
  Camera camera = Camera::orbit(-50, -20, 1.3, traversal.volume());
  camera.fovYDegrees = 20;
  double near = 0, far = 0;
  camera.clipRange(traversal.volume(), near, far);
  Frustum frustum = Frustum::fromMatrix(camera.projection(1, near, far) * camera.view());
  auto contributes = [](float min, float max) { return max > 0.4f && min < 0.9f; };
  TraversalResult r = traversal.run(camera, frustum, contributes);
  expectStatsAddUp(r, grid);
  for (const BrickDraw& b : r.bricks) {
    const MinMaxOctree::Range& range = grid.ranges[static_cast<size_t>(grid.index(b.key))];
    EXPECT_TRUE(contributes(range.min, range.max));
    EXPECT_TRUE(frustum.intersects(b.box));
  }
  checkVisibilityOrder(r.bricks, camera);
}

// A brick of B = 16 owning 16 x 11 x 7 voxels (a corner brick of a volume 16 + 16 x 16 + 11 x 16 + 7), in a volume
// whose voxel grid starts at `kBrickLo`, with random samples.
constexpr int kSubB = 16;
const Vec3i kBrickLo{16, 16, 16};
const Vec3i kBrickOwned{16, 11, 7};
const Vec3i kBrickDims{32, 27, 23};

// A blob at a random place plus noise, so that a threshold leaves some sub-blocks out and keeps others.
std::vector<float> randomBrick(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0, 1);
  const float cx = 16 * unit(rng), cy = 11 * unit(rng), cz = 7 * unit(rng);
  const int side = kSubB + 2;
  std::vector<float> samples(size_t(side * side * side));
  for (int z = 0; z < side; ++z)
    for (int y = 0; y < side; ++y)
      for (int x = 0; x < side; ++x) {
        const float d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz);
        samples[size_t((z * side + y) * side + x)] = std::exp(-d2 / 30.0f) + 0.05f * unit(rng);
      }
  return samples;
}

TEST(SubBlocks, RangesCoverExactlyTheSamplesTrilinearReads) {
  const std::vector<float> samples = randomBrick(21);
  const int side = kSubB + 2;
  for (int subBlock : {2, 4, 8}) {
    SubBlockRanges ranges(samples.data(), store::ValueType::F32, kSubB, subBlock, kBrickOwned);
    ASSERT_EQ(ranges.levels(), std::countr_zero(unsigned(kSubB / subBlock)));
    for (int level = 0; level <= ranges.levels(); ++level) {
      const int e = ranges.edge(level), n = 1 << level;
      for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
          for (int i = 0; i < n; ++i) {
            const int cell[3] = {i, j, k};
            bool exists = true;
            int lo[3],
                hi[3];  // data indices, inclusive: owned voxels [c * e, min((c + 1) * e, owned)) plus one each side
            for (int a = 0; a < 3; ++a) {
              exists = exists && cell[a] * e < kBrickOwned[a];
              lo[a] = cell[a] * e;
              hi[a] = int(std::min<int64_t>((cell[a] + 1) * e, kBrickOwned[a])) + 1;
            }
            ASSERT_EQ(ranges.exists(level, i, j, k), exists);
            if (!exists) continue;
            float mn = 2, mx = -1;
            for (int z = lo[2]; z <= hi[2]; ++z)
              for (int y = lo[1]; y <= hi[1]; ++y)
                for (int x = lo[0]; x <= hi[0]; ++x) {
                  mn = std::min(mn, samples[size_t((z * side + y) * side + x)]);
                  mx = std::max(mx, samples[size_t((z * side + y) * side + x)]);
                }
            const SubBlockRanges::Range r = ranges.range(level, i, j, k);
            EXPECT_EQ(r.min, mn) << "sub-block " << subBlock << " level " << level << " node " << i << "," << j << ","
                                 << k;
            EXPECT_EQ(r.max, mx);
          }
    }
  }
  EXPECT_THROW(SubBlockRanges(samples.data(), store::ValueType::F32, kSubB, 16, kBrickOwned), RenderInputError);
  EXPECT_THROW(SubBlockRanges(samples.data(), store::ValueType::F32, kSubB, 3, kBrickOwned), RenderInputError);
}

TEST(SubBlocks, BoxesCoverTheContributingBlocksOnceFrontToBack) {
  const std::vector<float> samples = randomBrick(22);
  const store::Vec3d spacing{1.0, 0.5, 2.0};
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> coord(-30, 30);
  const auto contributes = [](float, float max) { return max > 0.55f; };
  int constrained = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const int subBlock = trial % 3 == 0 ? 2 : 4;
    SubBlockRanges ranges(samples.data(), store::ValueType::F32, kSubB, subBlock, kBrickOwned);
    glm::dvec3 eye{coord(rng), coord(rng), coord(rng)};
    if (trial % 5 == 1) eye.x = voxelFace(kBrickLo.x + 8, kBrickDims.x, spacing.x);  // on a split plane
    const bool ortho = trial % 4 == 3;
    const Camera camera = lookingFrom(eye, ortho, eye + glm::dvec3(coord(rng), coord(rng), coord(rng) + 0.5));
    std::vector<VoxelSpan> spans;
    SubBlockWalkStats stats;
    subBlockBoxes(ranges, kBrickLo, 0, kBrickDims, spacing, camera, contributes, spans, stats);
    EXPECT_EQ(stats.boxes, int64_t(spans.size()));

    // Every finest block is drawn exactly once if it contributes and never otherwise.
    const int perAxis = kSubB / subBlock, L = ranges.levels();
    std::vector<int> covered(size_t(perAxis * perAxis * perAxis), 0);
    for (const VoxelSpan& s : spans)
      for (int64_t z = s.lo.z; z < s.hi.z; ++z)
        for (int64_t y = s.lo.y; y < s.hi.y; ++y)
          for (int64_t x = s.lo.x; x < s.hi.x; ++x)
            if ((x - kBrickLo.x) % subBlock == 0 && (y - kBrickLo.y) % subBlock == 0 &&
                (z - kBrickLo.z) % subBlock == 0)
              ++covered[size_t(((z - kBrickLo.z) / subBlock * perAxis + (y - kBrickLo.y) / subBlock) * perAxis +
                               (x - kBrickLo.x) / subBlock)];
    int64_t rejected = 0;
    for (int k = 0; k < perAxis; ++k)
      for (int j = 0; j < perAxis; ++j)
        for (int i = 0; i < perAxis; ++i) {
          if (!ranges.exists(L, i, j, k)) continue;
          const SubBlockRanges::Range r = ranges.range(L, i, j, k);
          const bool draws = contributes(r.min, r.max);
          rejected += draws ? 0 : 1;
          EXPECT_EQ(covered[size_t((k * perAxis + j) * perAxis + i)], draws ? 1 : 0) << i << "," << j << "," << k;
        }
    EXPECT_EQ(stats.subBlocksSkipped, rejected);
    ASSERT_GT(rejected, 0) << "the test data should leave some blocks out";

    std::vector<BrickDraw> boxes;
    for (const VoxelSpan& s : spans)
      boxes.push_back({store::BrickKey{}, voxelSpanBox(s.lo, s.hi, kBrickDims, spacing)});
    constrained += checkVisibilityOrder(boxes, camera);
  }
  EXPECT_GT(constrained, 60 * 20);
}

TEST(SubBlocks, ABrickWhoseBlocksAllContributeIsOneBox) {
  const std::vector<float> samples = randomBrick(24);
  SubBlockRanges ranges(samples.data(), store::ValueType::F32, kSubB, 2, kBrickOwned);
  std::vector<VoxelSpan> spans;
  SubBlockWalkStats stats;
  subBlockBoxes(
      ranges, kBrickLo, 0, kBrickDims, kTraversalSpacing, lookingFrom({0, 0, 90}), [](float, float) { return true; },
      spans, stats);
  ASSERT_EQ(spans.size(), 1u);
  EXPECT_EQ(spans[0].lo, kBrickLo);
  EXPECT_EQ(spans[0].hi, (Vec3i{kBrickLo.x + 16, kBrickLo.y + 11, kBrickLo.z + 7}));
  EXPECT_EQ(stats.subBlocksSkipped, 0);
}

TEST(TraversalInput, MismatchedGridsAndMissingPredicatesThrow) {
  Grid grid(8);
  EXPECT_THROW(OctreeTraversal(grid.octree, {41, 32, 17}, kB, kTraversalSpacing), RenderInputError);
  EXPECT_THROW(OctreeTraversal(grid.octree, kDims, 0, kTraversalSpacing), RenderInputError);
  EXPECT_THROW(OctreeTraversal(grid.octree, kDims, kB, {1, 0, 1}), RenderInputError);
  OctreeTraversal traversal(grid.octree, kDims, kB, kTraversalSpacing);
  EXPECT_THROW(traversal.run(lookingFrom({0, 0, 50}), Frustum{}, {}, {true, false, {}, {}}), RenderInputError);
  EXPECT_THROW(traversal.run(lookingFrom({0, 0, 0}, false, {0, 0, 0}), Frustum{}, {}, kEverything), RenderInputError);
}

}  // namespace
}  // namespace voxbrick::render
