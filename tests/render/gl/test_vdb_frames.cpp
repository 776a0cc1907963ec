// A .vdb rendered live gives the frames of the store `voxbrick prep` makes of it, bit for bit: a sparse grid and a
// dense one, level 0 and mixed levels, slicing and slabs, tight budgets, and through the `render` command.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "brickstore/read/VdbStore.h"
#include "image/Image.h"
#include "render/gl/GlFixtures.h"
#include "render/volume/FramePlan.h"
#include "support/TestSupport.h"
#include "support/VdbGrids.h"

namespace voxbrick::render {
namespace {

using test::meanBrightness;
using test::renderStore;
using test::ScratchDir;

Scene vdbScene(double lod, int slab) {
  Scene scene = test::lodScene(lod);
  scene.camera.distance = 2.0;
  scene.slab = slab;
  scene.raycast = false;
  return scene;
}

/// Expects the two frames to be the same floats, pixel for pixel.
void expectSameFrame(const image::ImageF& live, const image::ImageF& prepped, const std::string& what) {
  ASSERT_EQ(live.rgba.size(), prepped.rgba.size()) << what;
  size_t differ = 0;
  for (size_t i = 0; i < live.rgba.size(); ++i) differ += live.rgba[i] != prepped.rgba[i];
  EXPECT_EQ(differ, 0u) << what << ": max |diff| " << image::compareImages(live, prepped).maxAbs;
  if (differ) test::expectClose(live, prepped, 0, "vdb-" + what);
}

class VdbFrames : public ::testing::TestWithParam<bool> {
 protected:
  void SetUp() override {
    vdb = dir / "grid.vdb";
    test::writeVdb(vdb, {GetParam() ? test::sparseGrid() : test::denseGrid()});
    prepped = test::prep(vdb.string(), dir / "prepped", kBrick);
    live = store::VdbStore::open(vdb, {"", kBrick});
  }

  static constexpr int kBrick = 16;
  ScratchDir dir;
  std::filesystem::path vdb;
  std::shared_ptr<const store::BrickStore> prepped;
  std::shared_ptr<const store::VdbStore> live;
};

TEST_P(VdbFrames, EqualThePreppedStoreBitForBit) {
  const std::string grid = GetParam() ? "sparse" : "dense";
  bool mixedLevels = false;
  for (const double lod : {0.0, 8.0})
    for (const int slab : {0, 32}) {
      const std::string what = grid + "-lod" + std::to_string(int(lod)) + "-slab" + std::to_string(slab);
      const Scene scene = vdbScene(lod, slab);
      FrameStats liveStats, preppedStats;
      const image::ImageF a = renderStore(live, scene, &liveStats);
      const image::ImageF b = renderStore(prepped, scene, &preppedStats);
      EXPECT_GT(meanBrightness(b), 0.002) << what << ": a black frame proves nothing";
      expectSameFrame(a, b, what);
      EXPECT_EQ(liveStats.bricksDrawn, preppedStats.bricksDrawn) << what;
      EXPECT_EQ(liveStats.bricksPerLevel, preppedStats.bricksPerLevel) << what;
      if (lod > 0) {
        mixedLevels = mixedLevels || liveStats.bricksCoarse > 0;
        EXPECT_GT(live->bricksBuilt(1), 0) << what << ": coarse bricks come from the live grid";
      }
    }
  EXPECT_TRUE(mixedLevels) << "no frame drew a coarse level";
}

TEST_P(VdbFrames, EqualUnderTightBudgets) {
  // A GPU budget of three bricks draws level 0 in many batches; a host cache of six bricks evicts finer
  // bricks while the coarse ones are built from them.
  const std::string grid = GetParam() ? "sparse" : "dense";
  const size_t brickBytes = live->brickBytes();
  for (const double lod : {0.0, 8.0}) {
    const std::string what = grid + "-tight-lod" + std::to_string(int(lod));
    const Scene scene = vdbScene(lod, 32);
    auto cache = std::make_shared<store::BrickCache>(live, brickBytes * 6, 1);
    FrameStats stats;
    image::ImageF a;
    {
      VolumeRenderer renderer(test::context(), cache, brickBytes * 3);
      a = renderer.render(scene, &stats, test::batched());
    }
    const image::ImageF b = renderStore(prepped, scene, nullptr, brickBytes * 3, brickBytes * 6, test::batched());
    if (lod == 0) {
      EXPECT_GT(stats.batches, 1) << what;
    } else {
      EXPECT_GT(stats.bricksCoarse, 0) << what;
    }
    EXPECT_GT(cache->stats().evictions, 0u) << what;
    EXPECT_LE(cache->stats().peakResidentBytes, brickBytes * 6) << what;
    expectSameFrame(a, b, what);
  }
}

INSTANTIATE_TEST_SUITE_P(Grids, VdbFrames, ::testing::Values(true, false),
                         [](const ::testing::TestParamInfo<bool>& p) { return p.param ? "Sparse" : "Dense"; });

TEST(VdbFramesCommand, RenderOfAVdbEqualsRenderOfItsPreppedStore) {
  ScratchDir dir;
  test::writeVdb(dir / "sparse.vdb", {test::sparseGrid()});
  const std::string scene = " --size 96x80 --tf hot -q";
  auto run = [&](const std::string& args) {
    const auto r = test::runVoxbrick(args);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    return r.output;
  };
  run("prep " + (dir / "sparse.vdb").string() + " --brick 16 -q -o " + (dir / "prepped").string());
  run("render " + (dir / "sparse.vdb").string() + " --brick 16" + scene + " -o " + (dir / "live.png").string());
  run("render " + (dir / "prepped").string() + scene + " -o " + (dir / "prepped.png").string());
  const image::Image8 live = image::readPng(dir / "live.png"), prepped = image::readPng(dir / "prepped.png");
  ASSERT_EQ(live.rgba.size(), prepped.rgba.size());
  EXPECT_EQ(live.rgba, prepped.rgba);
  size_t lit = 0;
  for (size_t i = 0; i < live.rgba.size(); i += 4) lit += live.rgba[i] > 0;
  EXPECT_GT(lit, 50u) << "a black frame proves nothing";

  const auto badGrid = test::runVoxbrick("render " + (dir / "sparse.vdb").string() + " --grid missing -q -o " +
                                         (dir / "x.png").string());
  EXPECT_EQ(badGrid.exitCode, 1);
  EXPECT_NE(badGrid.output.find("has no grid named 'missing'"), std::string::npos) << badGrid.output;
}

// A sparse volume far larger than a dense cell table could hold (5 400³ voxels: 169³ bricks of 32, past the 2²²
// brick cells where the ray caster once gave way to slabs) ray-casts through the paged table: a page for each block
// of 8³ cells something is drawn in, and the frame is the slabs' frame of the same bricks.
TEST(VdbFrames, ASparseVolumeOfAnySizeRayCasts) {
  ScratchDir dir;
  openvdb::initialize();
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
  grid->setName("density");
  openvdb::FloatGrid::Accessor acc = grid->getAccessor();
  // Three balls: at both corners of the box, and in the middle.
  for (const int c : {6, 2700, 5393})
    for (int z = -6; z <= 6; ++z)
      for (int y = -6; y <= 6; ++y)
        for (int x = -6; x <= 6; ++x)
          if (x * x + y * y + z * z <= 36) acc.setValue(openvdb::Coord(c + x, c + y, c + z), float(1.0 - 0.02 * (x * x + y * y + z * z)));
  test::writeVdb(dir / "sparse.vdb", {grid});
  const auto live = store::VdbStore::open(dir / "sparse.vdb", {"", 32});
  ASSERT_EQ(live->meta().dims.x, 5400);
  Scene scene = test::lodScene(0);
  scene.width = scene.height = 48;
  scene.raycast = true;
  // Close to the middle ball (the box is centred on the origin), looking along the diagonal through all three.
  scene.camera = CameraSpec{};
  scene.camera.orbit = false;
  scene.camera.eye = {40, 40, 40};
  scene.camera.up = {0, 0, 1};
  FrameStats stats;
  const image::ImageF cast = renderStore(live, scene, &stats, size_t(64) << 20, size_t(64) << 20);
  const FramePlan plan = planFrame(scene, *live, kTransferTableTexels);
  EXPECT_TRUE(plan.raycast);
  EXPECT_EQ(plan.cellSize, 8) << "the sub-blocks are the cells";
  EXPECT_TRUE(stats.fallback.empty()) << stats.fallback;
  EXPECT_EQ(stats.slabPasses, 0);
  EXPECT_GT(stats.samples, 0);
  EXPECT_GT(meanBrightness(cast), 0.0);
  EXPECT_TRUE(plan.pagedCells) << "a table this large is paged";
  // The compute kernel reads the same paged table.
  Scene compute = scene;
  compute.raycaster = RayCaster::Compute;
  FrameStats computeStats;
  test::expectSameDrawing(renderStore(live, compute, &computeStats, size_t(64) << 20, size_t(64) << 20), cast, 0.0,
                          *live, scene, "sparse-5400-compute");
  EXPECT_EQ(computeStats.raycaster, "compute");
  EXPECT_EQ(computeStats.samples, stats.samples);
  scene.raycast = false;
  scene.slab = 32;
  const image::ImageF slabs = renderStore(live, scene, nullptr, size_t(64) << 20, size_t(64) << 20);
  test::expectSameDrawing(cast, slabs, 1.0 / 255, *live, scene, "sparse-5400");
}

}  // namespace
}  // namespace voxbrick::render
