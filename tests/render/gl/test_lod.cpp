// Level of detail: coarser pyramid levels where their voxels are no larger than `lod` pixels. Frames mixing levels
// are held to the reference sampling the same level in each region (no cracks, no double samples where levels meet),
// the traversal covers every region exactly once with neighbouring levels at most one apart, and lod 0 changes
// nothing.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "image/Image.h"
#include "render/core/RenderErrors.h"
#include "render/gl/GlFixtures.h"
#include "render/reference/ReferenceRenderer.h"
#include "render/volume/FramePlan.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::expectClose;
using test::lodScene;
using test::meanBrightness;
using test::prep;
using test::renderReference;
using test::renderStore;
using test::ScratchDir;

constexpr int kTexels = VolumeRenderer::kTransferTableTexels;

/// Levels drawn (those with at least one brick).
std::set<int> levelsDrawn(const FrameStats& stats) {
  std::set<int> out;
  for (size_t l = 0; l < stats.bricksPerLevel.size(); ++l)
    if (stats.bricksPerLevel[l] > 0) out.insert(int(l));
  return out;
}

double psnr(const image::ImageF& a, const image::ImageF& b) { return image::compareImages(a, b).psnr; }

TEST(Lod, MixedLevelsMatchTheReferenceOfTheSameLevels) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=128", dir / "b", 16);
  ASSERT_GE(s->levelCount(), 4);
  for (int slab : {0, 32}) {
    const std::string what = slab ? "slabs" : "slicing";
    Scene scene = lodScene(1.5);
    scene.slab = slab;
    scene.raycast = false;
    scene.ert = 0;
    FrameStats stats;
    const image::ImageF gpu = renderStore(s, scene, &stats);
    ASSERT_GT(meanBrightness(gpu), 0.01) << what;
    ASSERT_GE(levelsDrawn(stats).size(), 2u) << what << ": the camera must mix levels for this test to mean anything";
    EXPECT_GT(stats.bricksCoarse, 0) << what;

    ReferenceOptions options;
    options.brickLevels = brickLevels(planFrame(scene, *s, kTexels).visible, s->meta());
    const image::ImageF reference = renderReference(s, scene, options);
    Scene fine = scene;
    fine.lod = 0;
    const image::ImageF level0 = renderStore(s, fine);
    const image::ImageF reference0 = renderReference(s, fine);
    const double mixed = psnr(gpu, reference), whole = psnr(level0, reference0);
    std::cout << what << ": mixed levels against the same levels' reference " << mixed << " dB, level 0 against its "
              << whole << " dB, mixed against level 0 " << psnr(gpu, level0) << " dB\n";
    const double maxAbs = image::compareImages(gpu, reference).maxAbs;
    std::cout << what << ": max |diff| against the same levels' reference " << maxAbs << "\n";
    // Slicing samples every plane at every level, so it meets the same levels about as closely as level 0 meets
    // level 0 (a crack or a double sample where levels meet would cost tens of dB; level 0 reaches 100 dB here,
    // where what separates the two is float round-off, so the bar is at most 80 dB); slabs take every 2^m-th plane
    // in level m, a coarser step there, and stay far above the 40 dB a user would see.
    if (slab == 0) {
      EXPECT_GT(mixed, std::min(whole, 80.0) - 1.0) << what;
      EXPECT_LT(maxAbs, 2.0 / 255) << what;
    } else {
      EXPECT_GT(mixed, 60.0) << what;
      EXPECT_LT(maxAbs, 8.0 / 255) << what;
    }
  }
}

TEST(Lod, LevelZeroChangesNothing) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=64", dir / "b", 16);
  Scene scene = lodScene(0);
  FrameStats stats;
  const image::ImageF zero = renderStore(s, scene, &stats);
  EXPECT_EQ(stats.bricksCoarse, 0);
  // A threshold no coarser voxel meets draws level 0 everywhere, bit for bit.
  scene.lod = 1e-3;
  expectClose(renderStore(s, scene, &stats), zero, 0.0, "lod 1e-3");
  EXPECT_EQ(stats.bricksCoarse, 0);
}

TEST(Lod, OutOfCoreMixedLevelsEqualInCore) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=128", dir / "b", 16);
  Scene scene = lodScene(1.5);
  FrameStats whole, tight;
  const image::ImageF inCore = renderStore(s, scene, &whole);
  ASSERT_GE(levelsDrawn(whole).size(), 2u);
  ASSERT_EQ(whole.batches, 1);
  // Room for a handful of bricks: many batches, each mixing levels.
  const size_t brick = size_t(s->brickEdge()) * s->brickEdge() * s->brickEdge() * 4;
  const image::ImageF outOfCore = renderStore(s, scene, &tight, 6 * brick, size_t(256) << 20, test::batched());
  EXPECT_GT(tight.batches, 3);
  expectClose(outOfCore, inCore, 1.0 / 255, "lod out of core");
}

/// Every level-0 brick is covered at most once, and a coarse brick stands exactly for the level-0 bricks under it.
TEST(Lod, TraversalCoversEachRegionOnceWithNeighboursOneLevelApart) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=128", dir / "b", 8);
  const store::Vec3i grid = s->meta().levels[0].bricks;
  for (double lod : {0.5, 1.0, 2.0, 4.0})
    for (int azimuth = 0; azimuth < 360; azimuth += 45) {
      Scene scene = lodScene(lod);
      scene.width = scene.height = 256;
      scene.camera.azimuth = azimuth;
      scene.camera.distance = 1.2 + azimuth / 90.0;
      const FramePlan plan = planFrame(scene, *s, kTexels);
      const TraversalStats& st = plan.visible.stats;
      EXPECT_EQ((st.bricksDrawn - st.bricksCoarse) + st.bricksCoarsened + st.bricksSkippedEmpty + st.bricksCulled,
                grid.volume());
      const std::vector<int> cover = test::levelZeroCoverage(plan.visible.bricks, grid);
      for (int c : cover) ASSERT_LE(c, 1);
      const std::vector<uint8_t> levels = brickLevels(plan.visible, s->meta());
      int worst = 0;
      for (int64_t k = 0; k < grid.z; ++k)
        for (int64_t j = 0; j < grid.y; ++j)
          for (int64_t i = 0; i < grid.x; ++i) {
            const size_t here = size_t(i + grid.x * (j + grid.y * k));
            if (!cover[here]) continue;
            const int64_t step[3] = {1, grid.x, grid.x * grid.y};
            const bool inside[3] = {i + 1 < grid.x, j + 1 < grid.y, k + 1 < grid.z};
            for (int a = 0; a < 3; ++a)
              if (inside[a] && cover[here + size_t(step[a])])
                worst = std::max(worst, std::abs(int(levels[here]) - int(levels[here + size_t(step[a])])));
          }
      EXPECT_LE(worst, 1) << "lod " << lod << ", azimuth " << azimuth;
    }
}

TEST(Lod, CoarserWithDistanceAndThreshold) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=128", dir / "b", 16);
  auto coarse = [&](double lod, double distance) {
    Scene scene = lodScene(lod);
    scene.camera.distance = distance;
    return planFrame(scene, *s, kTexels).visible.stats;
  };
  EXPECT_EQ(coarse(0, 50).bricksCoarse, 0);
  EXPECT_LT(coarse(1, 1.5).bricksCoarsened, coarse(1, 4).bricksCoarsened);
  EXPECT_LT(coarse(1, 3).bricksCoarsened, coarse(4, 3).bricksCoarsened);
  // Far enough, the whole volume is one brick of the coarsest level.
  const TraversalStats far = coarse(1, 400);
  EXPECT_EQ(far.bricksDrawn, 1);
  EXPECT_EQ(int(far.bricksPerLevel.size()), s->levelCount());
}

TEST(Lod, SceneKey) {
  const Scene s = Scene::fromJson(R"({"lod": 2.5})", "scene");
  EXPECT_EQ(s.lod, 2.5);
  EXPECT_EQ(Scene().lod, 1.0);
  EXPECT_EQ(Scene::fromJson(s.toJson(), "round trip").lod, 2.5);
  EXPECT_THROW(Scene::fromJson(R"({"lod": -1})", "scene"), RenderInputError);
  EXPECT_THROW(Scene::fromJson(R"({"lod": 1e9})", "scene"), RenderInputError);
  EXPECT_THROW(Scene::fromJson(R"({"lod": "fine"})", "scene"), RenderInputError);
}

}  // namespace
}  // namespace voxbrick::render
