// Level of detail under a GPU budget far below the frame's bricks: the set is coarsened until the atlas holds it, so
// the frame is drawn in one batch, the next frame of the same view pages nothing, a slow drag pages only what came
// into view, and the image stays close to the full-budget frame's.
#include <gtest/gtest.h>

#include <iostream>
#include <string>

#include "image/Image.h"
#include "render/gl/GlFixtures.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

TEST(LodBudget, ASetCoarsenedToTheAtlasPagesNothingOnTheNextFrame) {
  test::ScratchDir dir;
  const auto s = test::prep("synthetic:blobs,n=128", dir / "b", 16);
  Scene scene = test::lodScene(0.5);
  scene.width = scene.height = 192;
  FrameStats full;
  const image::ImageF wanted = test::renderStore(s, scene, &full);
  ASSERT_GT(full.bricksDrawn, 100);
  ASSERT_EQ(full.bricksFitCoarsened, 0);

  // An atlas of a quarter of the bricks the level of detail wants.
  const size_t slot = BrickAtlas::slotBytes(s->type(), s->brickEdge(), AtlasFormat::Float);
  const int64_t capacity = full.bricksDrawn / 4;
  auto cache = std::make_shared<store::BrickCache>(s, size_t(256) << 20, 1);
  // Direct uploads: the whole budget is slots (staged, as Auto is on a GPU, an eighth of it would be the upload ring).
  VolumeRenderer renderer(test::context(), cache, size_t(capacity) * slot, AtlasFormat::Float, AtlasUploads::Direct);
  ASSERT_EQ(renderer.atlas().capacity(), capacity);
  FrameStats first, second, dragged;
  const image::ImageF fitted = renderer.render(scene, &first);
  EXPECT_LE(first.bricksDrawn, capacity);
  EXPECT_EQ(first.bricksFitCoarsened, full.bricksDrawn - first.bricksDrawn);
  EXPECT_EQ(first.batches, 1);
  EXPECT_EQ(first.bytesWanted, full.bricksDrawn * int64_t(slot));
  EXPECT_EQ(first.bytesBudget, capacity * int64_t(slot));
  EXPECT_GT(first.levelCoarsest, full.levelCoarsest);
  const image::ImageF again = renderer.render(scene, &second);
  EXPECT_EQ(second.bricksPagedIn, 0) << "a still view pages nothing once its set is resident";
  test::expectClose(again, fitted, 0.0, "lod-budget-again");

  const double psnr = image::compareImages(fitted, wanted).psnr;
  std::cout << "a quarter of the bricks: " << first.bricksDrawn << " of " << full.bricksDrawn << ", levels "
            << first.levelFinest << ".." << first.levelCoarsest << ", " << psnr << " dB against the full budget\n";
  EXPECT_GT(psnr, 50.0);  // 61.7 dB measured (llvmpipe)

  // A slow drag: two degrees about the volume.
  scene.camera.azimuth += 2;
  renderer.render(scene, &dragged);
  std::cout << "a two-degree drag paged " << dragged.bricksPagedIn << " of " << dragged.bricksDrawn << " bricks\n";
  EXPECT_EQ(dragged.batches, 1);
  EXPECT_LT(dragged.bricksPagedIn * 4, dragged.bricksDrawn);

  const nlohmann::json json = first.toJson();
  for (const char* key : {"bytes_wanted", "bytes_budget", "bricks_fit_coarsened", "level_finest", "level_coarsest"})
    EXPECT_TRUE(json.contains(key)) << key;
}

TEST(LodBudget, WithoutTheFitTheSameBudgetRepagesEveryFrame) {
  test::ScratchDir dir;
  const auto s = test::prep("synthetic:blobs,n=128", dir / "b", 16);
  Scene scene = test::lodScene(0.5);
  FrameStats full;
  test::renderStore(s, scene, &full);
  const size_t slot = BrickAtlas::slotBytes(s->type(), s->brickEdge(), AtlasFormat::Float);
  auto cache = std::make_shared<store::BrickCache>(s, size_t(256) << 20, 1);
  VolumeRenderer renderer(test::context(), cache, size_t(full.bricksDrawn / 4) * slot);
  FrameStats stats;
  for (int frame = 0; frame < 2; ++frame) renderer.render(scene, &stats, test::batched());
  EXPECT_GT(stats.batches, 1);
  EXPECT_GT(stats.bricksPagedIn, full.bricksDrawn / 2) << "LRU over a set larger than the atlas pages it again";
}

}  // namespace
}  // namespace voxbrick::render
