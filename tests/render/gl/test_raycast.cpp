// The frame ray caster against slicing and slabs: the same samples on the same global planes, found through the
// cell table instead of a proxy per box, must give their image (within 1/255) for any camera, bricking, sub-block,
// budget and level of detail; termination stays within its bound; the cell table's limits fall back to slabs.
#include <gtest/gtest.h>

#include <string>

#include "image/Image.h"
#include "render/core/RenderErrors.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/volume/CellTable.h"
#include "render/reference/ReferenceRenderer.h"
#include "render/volume/FramePlan.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::expectClose;
using test::meanBrightness;
using test::prep;
using test::renderStore;
using test::ScratchDir;

/// Slicing, the baseline.
Scene slicing(const std::string& tf) { return test::slicingScene(tf); }

Scene rayCast(Scene scene) {
  scene.raycast = true;
  return scene;
}

/// The march's cameras, with the axis view from the far side as well.
std::vector<std::pair<std::string, CameraSpec>> cameras() { return test::marchCameras(true); }

TEST(RayCast, GivesSlicingsImageForEveryCameraAndCell) {
  ScratchDir dir;
  const auto s = prep("synthetic:marschner-lobb,n=40", dir / "ml", 16);
  for (const auto& [name, camera] : cameras()) {
    Scene scene = slicing("hot");
    scene.camera = camera;
    const image::ImageF sliced = renderStore(s, scene);
    ASSERT_GT(meanBrightness(sliced), 0.005) << name;
    for (int subBlock : {0, 4}) {
      Scene cast = rayCast(scene);
      cast.subBlock = subBlock;
      FrameStats stats;
      test::expectSameDrawing(renderStore(s, cast, &stats), sliced, 1.0 / 255, *s, scene,
                              "raycast-sub" + std::to_string(subBlock) + "-" + name);
      // One fragment per pixel whose ray meets the volume, at most.
      EXPECT_LE(stats.fragments, int64_t(scene.width) * scene.height) << name;
      EXPECT_GT(stats.samples, 10 * stats.fragments) << name << ": a whole ray per fragment";
      EXPECT_EQ(stats.slabPasses, 0) << name;
    }
  }
}

TEST(RayCast, TakesTheSamplesSlabsTake) {
  ScratchDir dir;
  const auto s = prep("synthetic:sparse,n=96", dir / "s", 16);
  Scene scene = slicing("sparse");
  scene.slab = 8;
  scene.subBlock = 4;
  FrameStats slabbed, cast;
  const image::ImageF slabs = renderStore(s, scene, &slabbed);
  ASSERT_GT(meanBrightness(slabs), 0.001);
  expectClose(renderStore(s, rayCast(scene), &cast), slabs, 1.0 / 255, "raycast-vs-slabs");
  // Every sample a slab takes in a box, the ray caster takes in the box's cells (samples exactly on a face between
  // an empty cell and a drawn one may go either way; they add nothing).
  EXPECT_NEAR(double(cast.samples), double(slabbed.samples), 0.01 * double(slabbed.samples));
  EXPECT_LT(cast.fragments * 4, slabbed.fragments) << "one fragment per pixel, not per box and slab";
  // Sub-blocks skip empty space inside bricks here too: fewer samples than whole bricks would take.
  FrameStats whole;
  scene.subBlock = 0;
  renderStore(s, rayCast(scene), &whole);
  EXPECT_LT(cast.samples * 10, whole.samples * 9);
}

TEST(RayCast, ShadingAndPreIntegration) {
  ScratchDir dir;
  const auto s = prep("synthetic:sparse,n=96", dir / "s", 16);
  Scene scene = slicing("sparse");
  scene.shading = true;
  const image::ImageF sliced = renderStore(s, scene);
  ASSERT_GT(meanBrightness(sliced), 0.001);
  for (int subBlock : {0, 4}) {
    Scene cast = rayCast(scene);
    cast.subBlock = subBlock;
    test::expectSameDrawing(renderStore(s, cast), sliced, 1.0 / 255, *s, scene,
                            "raycast-shaded-sub" + std::to_string(subBlock));
  }
  // Pre-integrated: a whole-brick cell is the slab's box, so the back samples are read alike.
  scene.shading = false;
  scene.preIntegration = true;
  scene.slab = 16;
  scene.step = 1;
  const image::ImageF slabs = renderStore(s, scene);
  ASSERT_GT(meanBrightness(slabs), 0.001);
  const image::ImageF cast = renderStore(s, rayCast(scene));
  test::expectSameDrawing(cast, slabs, 1.0 / 255, *s, scene, "raycast-pre-integrated");
  scene.preIntegration = false;
  EXPECT_GT(image::compareImages(renderStore(s, rayCast(scene)), cast).maxAbs, 4.0 / 255)
      << "the table is used: post-classification at this step differs";
}

TEST(RayCast, OutOfCoreEqualsInCoreAndTerminationStaysWithinItsBound) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=48", dir / "b", 8);
  Scene scene = rayCast(slicing("hot"));
  scene.transferFunction = TransferFunction::parse(
      R"({"points": [[0, 0, 0, 0, 0], [0.04, 0, 0, 0, 0], [0.08, 1, 0.6, 0.3, 0.9], [1, 1, 1, 1, 1]]})", "opaque");
  scene.subBlock = 4;
  for (const auto& [name, camera] : cameras()) {
    scene.camera = camera;
    scene.ert = 0;
    FrameStats full;
    const image::ImageF reference = renderStore(s, scene, &full);
    ASSERT_GT(meanBrightness(reference), 0.005) << name;
    EXPECT_EQ(full.samplesTerminated, 0) << name;
    FrameStats tight;
    // A budget of a few bricks: many batches, composited one after the other along every ray.
    expectClose(renderStore(s, scene, &tight, size_t(10) * 10 * 10 * 4 * 6, size_t(256) << 20, test::batched()),
                reference, 1.0 / 255, "raycast-out-of-core-" + name);
    EXPECT_GT(tight.batches, 5) << name;
    for (double ert : {0.95, 0.999}) {
      scene.ert = ert;
      FrameStats cut;
      // What a terminated ray leaves out is at most its remaining transmittance, 1 - ert, in every channel.
      expectClose(renderStore(s, scene, &cut), reference, (1 - ert) + 1.0 / 255, "raycast-ert-" + name);
      if (name == "oblique") {
        EXPECT_LT(cut.samples * (ert < 0.99 ? 2 : 1), full.samples) << ert;
        EXPECT_GT(cut.samplesTerminated, 0) << ert;
      }
      // Out of core the silhouette map keeps terminated pixels from later batches.
      FrameStats pagedCut;
      expectClose(renderStore(s, scene, &pagedCut, size_t(10) * 10 * 10 * 4 * 6, size_t(256) << 20, test::batched()),
                  reference, (1 - ert) + 1.0 / 255, "raycast-ert-out-of-core-" + name);
      if (name == "oblique") {
        EXPECT_LT(pagedCut.fragments, tight.fragments) << ert;
      }
    }
  }
}

TEST(RayCast, MixedLevelsGiveSlabsImage) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=128", dir / "b", 16);
  for (int subBlock : {0, 8}) {
    Scene scene = test::lodScene(1.5);
    scene.ert = 0;
    scene.slab = 32;
    scene.raycast = false;
    scene.subBlock = subBlock;
    FrameStats slabbed, cast;
    const image::ImageF slabs = renderStore(s, scene, &slabbed);
    ASSERT_GT(meanBrightness(slabs), 0.01);
    ASSERT_GT(slabbed.bricksCoarse, 0) << "the camera must mix levels for this test to mean anything";
    expectClose(renderStore(s, rayCast(scene), &cast), slabs, 1.0 / 255, "raycast-lod-sub" + std::to_string(subBlock));
    EXPECT_NEAR(double(cast.samples), double(slabbed.samples), 0.01 * double(slabbed.samples));
    // Out of core, each batch mixing levels.
    const size_t brick = size_t(s->brickEdge()) * s->brickEdge() * s->brickEdge() * 4;
    FrameStats tight;
    expectClose(renderStore(s, rayCast(scene), &tight, 6 * brick, size_t(256) << 20, test::batched()), slabs, 1.0 / 255,
                "raycast-lod-out-of-core-sub" + std::to_string(subBlock));
    EXPECT_GT(tight.batches, 3);
  }
}

TEST(RayCast, CellTableSizeAndFallback) {
  // Sub-blocks are the cells while the paged table's directory stays small (an entry per 8^3 cells); coarser
  // cells, up to bricks, beyond.
  EXPECT_EQ(rayCastCellSize({301, 370, 316}, 8, 32), 8);
  EXPECT_EQ(rayCastCellSize({301, 370, 316}, 0, 32), 32);
  EXPECT_EQ(rayCastCellSize({2048, 2048, 2048}, 8, 32), 8);
  EXPECT_EQ(rayCastCellSize({8192, 8192, 8192}, 8, 32), 8);
  EXPECT_EQ(rayCastCellSize({16384, 16384, 32767}, 8, 32), 16);
  // Past 16-bit atlas offsets: texture slabs instead.
  EXPECT_EQ(rayCastCellSize({40000, 16, 16}, 8, 32), 0);

  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=48", dir / "b", 16);
  Scene scene = rayCast(slicing("hot"));
  scene.subBlock = 4;
  const FramePlan plan = planFrame(scene, *s, kTransferTableTexels);
  EXPECT_TRUE(plan.raycast);
  EXPECT_EQ(plan.cellSize, 4);
  EXPECT_EQ(plan.slab, 0);
  EXPECT_TRUE(plan.marches());
  EXPECT_EQ(plan.planeStride(2), 4) << "coarse levels take every 2^m-th plane, as slabs";
  EXPECT_TRUE(plan.fallback.empty());

  // A volume the table cannot hold is drawn with slabs, and the frame says so (no silent fallback).
  const store::Vec3i rod{40000, 8, 8};
  std::vector<uint8_t> values(size_t(rod.volume()));
  for (size_t i = 0; i < values.size(); ++i) values[i] = uint8_t((i % 40000) * 255 / 39999);
  const auto long_ = test::prepArray<uint8_t>(rod, store::ValueType::U8, std::move(values), dir / "rod", 8);
  Scene rodScene = rayCast(slicing("hot"));
  rodScene.width = rodScene.height = 32;
  FrameStats stats;
  renderStore(long_, rodScene, &stats);
  EXPECT_GT(stats.slabPasses, 0) << "drawn with slabs";
  EXPECT_NE(stats.fallback.find("texture slabs"), std::string::npos) << stats.fallback;
  EXPECT_NE(stats.fallback.find("40000x8x8"), std::string::npos) << stats.fallback;
  EXPECT_EQ(stats.toJson().value("fallback", ""), stats.fallback);
}

TEST(RayCast, EmptyCellsLeapOutOfTheLargestEmptyBlock) {
  std::vector<glm::i16vec4> cells(CellTable::kPageCells, glm::i16vec4(0, 0, 0, CellTable::kNothing));
  auto at = [&](int x, int y, int z) -> glm::i16vec4& { return cells[size_t((z * 8 + y) * 8 + x)]; };
  at(1, 1, 1) = glm::i16vec4(5, 6, 7, 0);                       // drawn
  at(7, 7, 7) = glm::i16vec4(0, 0, 0, CellTable::kOtherBatch);  // another batch's: not empty
  EXPECT_FALSE(computePageLeaps(cells.data()));
  EXPECT_EQ(at(1, 1, 1), glm::i16vec4(5, 6, 7, 0)) << "a drawn cell keeps its payload";
  EXPECT_EQ(at(0, 0, 0).x, 0) << "its 2-block holds the drawn cell";
  EXPECT_EQ(at(2, 0, 0).x, 1) << "an empty 2-block inside a 4-block that is not";
  EXPECT_EQ(at(4, 0, 0).x, 2) << "an empty 4-block inside the 8-block that is not";
  EXPECT_EQ(at(6, 6, 6).x, 0) << "a brick of another batch is not nothing";
  EXPECT_EQ(at(4, 4, 4).x, 1) << "its 4-block holds the other batch's cell";
  EXPECT_EQ(at(7, 7, 7).w, CellTable::kOtherBatch);
  // A page with nothing to draw at all leaps its whole block (and is given up: the directory says so).
  std::vector<glm::i16vec4> empty(CellTable::kPageCells, glm::i16vec4(0, 0, 0, CellTable::kNothing));
  EXPECT_TRUE(computePageLeaps(empty.data()));
  for (const glm::i16vec4& c : empty) EXPECT_EQ(c.x, CellTable::kMaxLeapLevel);
}

TEST(RayCast, IsTheDefaultDrawing) {
  EXPECT_TRUE(Scene().raycast);
  EXPECT_TRUE(Scene::fromJson("{}", "t").raycast) << "a request without drawing keys";
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=48", dir / "b", 16);
  Scene scene;
  scene.width = 64;
  scene.height = 48;
  FrameStats stats;
  const image::ImageF frame = renderStore(s, scene, &stats);
  ASSERT_GT(meanBrightness(frame), 0.005);
  EXPECT_EQ(stats.slabPasses, 0) << "no slab drawn";
  EXPECT_GE(stats.batches, 1);
  EXPECT_LE(stats.fragments, int64_t(64) * 48 * stats.batches) << "at most one fragment a pixel and batch";
  EXPECT_GT(stats.samples, stats.fragments) << "each marching its ray";
}

TEST(RayCast, TheSceneKeyIsChecked) {
  EXPECT_TRUE(Scene::fromJson(R"({"raycast": true})", "t").raycast);
  EXPECT_THROW(Scene::fromJson(R"({"raycast": 1})", "t"), RenderInputError);
  // A slab size asks for slicing or slabs unless the request says "raycast" too.
  Scene def;
  def.raycast = true;
  EXPECT_FALSE(Scene::fromJson(R"({"slab": 0})", "t").raycast);
  EXPECT_TRUE(Scene::fromJson(R"({"slab": 0, "raycast": true})", "t").raycast);
  EXPECT_TRUE(Scene::fromJson(def.toJson(), "t").raycast) << "toJson keeps it";
  def.raycast = false;
  EXPECT_FALSE(Scene::fromJson(def.toJson(), "t").raycast);
}

}  // namespace
}  // namespace voxbrick::render
