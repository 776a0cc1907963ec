// Fitting a frame's bricks to a budget, without GL: a plan that needs more bricks than the budget holds is coarsened
// until it fits, still covers every level-0 brick exactly once (drawn, skipped or culled), coarsens the far and the
// transparent side first, and with room enough is the plan of today.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "render/RenderFixtures.h"
#include "render/volume/FramePlan.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

constexpr int kWorkingSetTexels = 4096;

std::vector<store::BrickKey> keys(const FramePlan& plan) {
  std::vector<store::BrickKey> out;
  for (const BrickDraw& d : plan.visible.bricks) out.push_back(d.key);
  return out;
}

/// Boxes of the bricks the fit drew coarser than the level of detail chose, and of those it kept.
void splitByLevel(const FramePlan& fitted, const FramePlan& wanted, const store::StoreMeta& meta,
                  std::vector<Box>& coarsened, std::vector<Box>& kept) {
  const std::vector<uint8_t> before = brickLevels(wanted.visible, meta);
  const store::Vec3i& grid = meta.levels[0].bricks;
  for (const BrickDraw& d : fitted.visible.bricks) {
    const int m = int(d.key.level);
    const size_t first =
        size_t((int64_t(d.key.i) << m) + grid.x * ((int64_t(d.key.j) << m) + grid.y * (int64_t(d.key.k) << m)));
    (before[first] < m ? coarsened : kept).push_back(d.box);
  }
}

TEST(WorkingSetFit, ACoarsenedPlanFitsAndCoversEachBrickOnce) {
  test::ScratchDir dir;
  const auto s = test::prep("synthetic:blobs,n=128", dir / "b", 8);
  const store::Vec3i grid = s->meta().levels[0].bricks;
  Scene scene = test::lodScene(0.5);
  scene.width = scene.height = 256;
  const FramePlan wanted = planFrame(scene, *s, kWorkingSetTexels);
  const int64_t full = int64_t(wanted.visible.bricks.size());
  ASSERT_GT(full, 500);
  const std::vector<int> wantedCover = test::levelZeroCoverage(wanted.visible.bricks, grid);
  for (int64_t capacity : {full - 1, full / 2, full / 5, int64_t(40)})
    for (bool atlas : {true, false}) {
      const std::string what = "capacity " + std::to_string(capacity) + (atlas ? " (atlas)" : " (host)");
      const BrickBudget budget = atlas ? BrickBudget{capacity, 0} : BrickBudget{0, capacity};
      const FramePlan fitted = planFrame(scene, *s, kWorkingSetTexels, budget);
      EXPECT_EQ(fitted.bricksWanted, full) << what;
      EXPECT_LE(int64_t(fitted.visible.bricks.size()), capacity) << what;
      EXPECT_GT(int64_t(fitted.visible.bricks.size()), capacity - 8) << what << ": coarsened more than it needed";
      const TraversalStats& st = fitted.visible.stats;
      EXPECT_EQ((st.bricksDrawn - st.bricksCoarse) + st.bricksCoarsened + st.bricksSkippedEmpty + st.bricksCulled,
                grid.volume())
          << what;
      const std::vector<int> cover = test::levelZeroCoverage(fitted.visible.bricks, grid);
      for (size_t b = 0; b < cover.size(); ++b) {
        ASSERT_LE(cover[b], 1) << what << ": brick " << b << " drawn twice";
        ASSERT_GE(cover[b], wantedCover[b]) << what << ": brick " << b << " left out";
      }
      EXPECT_EQ(keys(planFrame(scene, *s, kWorkingSetTexels, budget)), keys(fitted)) << what << ": not deterministic";
    }
}

TEST(WorkingSetFit, WithRoomEnoughThePlanIsUnchanged) {
  test::ScratchDir dir;
  const auto s = test::prep("synthetic:blobs,n=64", dir / "b", 8);
  Scene scene = test::lodScene(0.5);
  const FramePlan wanted = planFrame(scene, *s, kWorkingSetTexels);
  const int64_t full = int64_t(wanted.visible.bricks.size());
  for (const BrickBudget& budget : {BrickBudget{full, 0}, BrickBudget{0, full}, BrickBudget{full * 4, full}}) {
    const FramePlan fitted = planFrame(scene, *s, kWorkingSetTexels, budget);
    EXPECT_EQ(keys(fitted), keys(wanted));
    EXPECT_EQ(fitted.visible.stats.bricksCoarse, wanted.visible.stats.bricksCoarse);
  }
  // lod 0 asks for level 0 everywhere: never coarsened, drawn in batches instead.
  scene.lod = 0;
  EXPECT_EQ(keys(planFrame(scene, *s, kWorkingSetTexels, {8, 8})), keys(planFrame(scene, *s, kWorkingSetTexels)));
}

TEST(WorkingSetFit, TheFarSideIsCoarsenedFirst) {
  test::ScratchDir dir;
  const auto s = test::prep("synthetic:blobs,n=128", dir / "b", 8);
  Scene scene = test::lodScene(0.25);
  scene.width = scene.height = 256;
  scene.camera.distance = 1.1;  // close: the near and far halves differ in size on screen
  scene.transferFunction = TransferFunction({{0.0, {1, 1, 1, 0.3}}, {1.0, {1, 1, 1, 0.3}}});
  const FramePlan wanted = planFrame(scene, *s, kWorkingSetTexels);
  const FramePlan fitted = planFrame(scene, *s, kWorkingSetTexels, {int64_t(wanted.visible.bricks.size()) * 3 / 4, 0});
  std::vector<Box> coarsened, kept;
  splitByLevel(fitted, wanted, s->meta(), coarsened, kept);
  ASSERT_FALSE(coarsened.empty());
  ASSERT_FALSE(kept.empty());
  const auto meanDepth = [&](const std::vector<Box>& boxes) {
    double sum = 0;
    for (const Box& b : boxes) sum += glm::dot(b.center() - fitted.camera.eye, fitted.camera.viewDirection());
    return sum / double(boxes.size());
  };
  std::cout << "mean depth: coarsened " << meanDepth(coarsened) << ", kept " << meanDepth(kept) << "\n";
  EXPECT_GT(meanDepth(coarsened), meanDepth(kept) * 1.2);
}

TEST(WorkingSetFit, TheTransparentSideIsCoarsenedFirst) {
  test::ScratchDir dir;
  // value = x over 64^3: under this transfer function the low-x half is nearly transparent, the high half opaque.
  const store::Vec3i n{64, 64, 64};
  std::vector<float> values(size_t(n.volume()));
  for (size_t v = 0; v < values.size(); ++v) values[v] = float(v % size_t(n.x));
  const auto s = test::prepArray(n, store::ValueType::F32, values, dir / "ramp.vbs", 8);
  Scene scene = test::lodScene(1e-3);  // on, but level 0 everywhere
  scene.camera.orthographic = true;    // every brick of a level the same size on screen: only opacity differs
  scene.cullFrustum = false;
  scene.transferFunction =
      TransferFunction({{0.0, {1, 1, 1, 0.02}}, {0.5, {1, 1, 1, 0.02}}, {0.5, {1, 1, 1, 0.8}}, {1.0, {1, 1, 1, 0.8}}});
  const FramePlan wanted = planFrame(scene, *s, kWorkingSetTexels);
  ASSERT_EQ(wanted.visible.bricks.size(), 512u);
  // 7 bricks go per merge of eight: 16 merges, and the nearly transparent level-1 nodes (x < 16) number 32.
  const FramePlan fitted = planFrame(scene, *s, kWorkingSetTexels, {512 - 16 * 7, 0});
  std::vector<Box> coarsened, kept;
  splitByLevel(fitted, wanted, s->meta(), coarsened, kept);
  ASSERT_EQ(coarsened.size(), 16u);
  const double lowSide = fitted.volume.min.x + 0.25 * fitted.volume.extent().x;  // voxel 16 of 64
  for (const Box& b : coarsened) EXPECT_LE(b.max.x, lowSide + 1e-9) << "an opaque node was coarsened first";
}

}  // namespace
}  // namespace voxbrick::render
