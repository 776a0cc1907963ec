// GPU budgets that hold: an atlas never outgrows its budget, and a RenderEngine keeps the atlases of all the datasets
// it draws within one budget, releasing the renderer used least recently, with frames unchanged; making a renderer is
// reported as the frame's warm-up.
#include <gtest/gtest.h>

#include "render/core/Dataset.h"
#include "render/engine/Datasets.h"
#include "render/engine/RenderEngine.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/volume/BrickAtlas.h"
#include "render/volume/BrickStoreDataset.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::ScratchDir;

TEST(GpuBudget, AnAtlasNeverOutgrowsItsBudget) {
  const int edge = 18;
  const size_t slot = BrickAtlas::slotBytes(store::ValueType::F32, edge, AtlasFormat::Float);
  ASSERT_EQ(slot, size_t(edge) * edge * edge * 4);
  const int perAxis = test::context().limits().max3DTextureSize / edge;
  // Slot counts around one row and one layer of the texture, where rounding up to whole rows would overshoot. Direct
  // uploads, so that the whole budget is slots; staged, the ring takes up to an eighth of it first (on a GPU, where
  // Auto stages) and the slots fill the rest.
  for (AtlasUploads uploads : {AtlasUploads::Direct, AtlasUploads::Staged})
    for (int slots : {1, 7, perAxis - 1, perAxis + 1, 2 * perAxis + 3, perAxis * 3 + perAxis / 2}) {
      const size_t budget = size_t(slots) * slot + slot / 2;
      const size_t ring = uploads == AtlasUploads::Staged
                              ? BrickAtlas::stagingBytes(store::ValueType::F32, edge, budget, AtlasFormat::Float)
                              : 0;
      BrickAtlas atlas(test::context(), store::ValueType::F32, edge, budget, 1 << 20, AtlasFormat::Float, uploads);
      const std::string what = std::to_string(slots) + " slots, " + (ring > 0 ? "staged" : "direct");
      EXPECT_LE(atlas.bytes(), budget) << what;
      const int room = int((budget - ring) / slot);
      EXPECT_GE(atlas.capacity(), room * 9 / 10) << what << ": rows are balanced, few slots are lost";
      EXPECT_LE(size_t(atlas.capacity()) * slot, atlas.bytes());
    }
}

TEST(GpuBudget, AnEngineKeepsAllItsAtlasesWithinOneBudget) {
  ScratchDir dir;
  std::vector<std::shared_ptr<const Dataset>> datasets;
  for (int n = 0; n < 5; ++n) {
    const auto path = dir / ("d" + std::to_string(n));
    test::prep("synthetic:blobs,n=64,seed=" + std::to_string(n + 1), path, 16);
    datasets.push_back(openDataset("d" + std::to_string(n), path, size_t(64) << 20));
  }
  const auto& store = *static_cast<const BrickStoreDataset&>(*datasets[0]).store();
  const size_t oneAtlas =
      size_t(store.level(0).bricksTotal()) * BrickAtlas::slotBytes(store.type(), store.brickEdge(), AtlasFormat::Float);
  // Room for two whole atlases, not three.
  const size_t budget = oneAtlas * 5 / 2;
  RenderEngine engine({Backend::Auto, budget, AtlasFormat::Float});
  Scene scene;
  scene.width = scene.height = 48;
  // The view these bounds were set for (before the fitted, +z-up default): the data fills the frame.
  scene.camera.distance = 2.5;
  scene.camera.upAxis = UpAxis::PosY;
  scene.transferFunction = TransferFunction::load("hot");
  std::vector<image::ImageF> first;
  for (int round = 0; round < 3; ++round)
    for (size_t d = 0; d < datasets.size(); ++d) {
      const image::ImageF frame = engine.render(datasets[d], scene);
      EXPECT_LE(engine.gpuBytes(), budget) << "round " << round << ", dataset " << d;
      EXPECT_GE(engine.gpuBytes(), oneAtlas) << "the atlas being drawn is whole";
      if (round == 0) {
        ASSERT_GT(test::meanBrightness(frame), 0.01);
        first.push_back(frame);
      } else {
        test::expectClose(frame, first[d], 0.0, "dataset " + std::to_string(d) + " after its renderer was released");
      }
    }
  EXPECT_LE(engine.peakGpuBytes(), budget);
  EXPECT_GE(engine.renderersReleased(), 12u) << "round robin over five datasets with room for two";

  // A dataset larger than the budget draws out of core within it.
  RenderEngine tight({Backend::Auto, oneAtlas / 3, AtlasFormat::Float});
  FrameStats stats;
  test::expectClose(tight.render(datasets[0], scene, &stats, test::batched()), first[0], 1.0 / 255, "out of core");
  EXPECT_GT(stats.batches, 1);
  EXPECT_LE(tight.gpuBytes(), oneAtlas / 3);
}

/// Two small grids (blobs of two seeds), an engine with room for both, and a 32x32 scene.
struct TwoDatasets {
  ScratchDir dir;
  std::shared_ptr<const Dataset> a, b;
  RenderEngine engine{{Backend::Auto, size_t(256) << 20, AtlasFormat::Float}};
  Scene scene;
  TwoDatasets() {
    test::prep("synthetic:blobs,n=64,seed=1", dir / "a", 16);
    test::prep("synthetic:blobs,n=64,seed=2", dir / "b", 16);
    a = openDataset("a", dir / "a", size_t(64) << 20);
    b = openDataset("b", dir / "b", size_t(64) << 20);
    scene.width = scene.height = 32;
  }
};

TEST(GpuBudget, AQuarantinedDatasetGivesItsAtlasBack) {
  TwoDatasets t;
  t.engine.render(t.a, t.scene);
  const size_t one = t.engine.gpuBytes();
  t.engine.render(t.b, t.scene);
  EXPECT_EQ(t.engine.gpuBytes(), 2 * one);
  t.a->quarantine("its bricks failed their checks");  // what the server does when a frame of it meets a bad brick
  t.engine.render(t.b, t.scene);
  EXPECT_EQ(t.engine.gpuBytes(), one) << "the quarantined dataset's renderer is released at the next frame";
}

// A frame's one-time work on its context is reported apart (FrameStats::msWarmup, which the server's scheduler charges
// to no session): the renderer made for a dataset the engine had not drawn, and programs built; a frame of a warm
// renderer reports none.
TEST(GpuBudget, AFrameReportsTheRendererItMadeAsWarmUp) {
  TwoDatasets t;
  FrameStats stats;
  t.engine.render(t.a, t.scene, &stats);
  EXPECT_GT(stats.msWarmup, 0.0) << "the first frame made the renderer";
  EXPECT_DOUBLE_EQ(stats.toJson()["ms"]["warmup"].get<double>(), stats.msWarmup);
  // A renderer may build a program on a later frame (a kernel chosen by measurement on a GPU); by the fourth frame of
  // the same scene there is nothing left to build.
  for (int frame = 0; frame < 3; ++frame) t.engine.render(t.a, t.scene, &stats);
  EXPECT_EQ(stats.msWarmup, 0.0) << "the renderer was there";
  t.engine.render(t.b, t.scene, &stats);
  EXPECT_GT(stats.msWarmup, 0.0) << "another dataset: another renderer";
  t.engine.render(t.a, t.scene, &stats);
  EXPECT_EQ(stats.msWarmup, 0.0);
}

}  // namespace
}  // namespace voxbrick::render
