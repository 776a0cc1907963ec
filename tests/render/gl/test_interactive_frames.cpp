// Interactive frames on the GL renderer (render/core/Interactive.h through RenderEngine): a small budget draws fewer
// samples and is scaled up to the requested size, or to the smaller size a video stream is sent at; and frames split finely for prompt cancellation (checkpoint
// intervals sized by cost: bands and tiles, slab tiles, slicing runs) are the same frames, for every technique.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>

#include "render/core/Interactive.h"
#include "render/core/RenderErrors.h"
#include "render/engine/Datasets.h"
#include "render/engine/RenderEngine.h"
#include "render/gl/GlFixtures.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::ScratchDir;

Scene blobScene() {
  Scene scene;
  scene.width = 160, scene.height = 120;
  scene.transferFunction = TransferFunction::load("hot");
  return scene;
}

/// The blobs at 96³ in bricks of 16, prepped in `dir` and opened.
std::shared_ptr<const Dataset> blobs(const ScratchDir& dir) {
  test::prep("synthetic:blobs,n=96", dir / "blobs", 16);
  return openDataset("blobs", dir / "blobs", size_t(256) << 20);
}

TEST(InteractiveFrames, ASmallBudgetDrawsFewerSamplesScaledUpToTheRequestedSize) {
  ScratchDir dir;
  const auto dataset = blobs(dir);
  RenderEngine engine({});
  Scene scene = blobScene();
  FrameStats exact;
  engine.render(dataset, scene);  // the first frame pages; the next ones are warm and equal
  const image::ImageF full = engine.render(dataset, scene, &exact);
  ASSERT_GT(test::meanBrightness(full), 0.01);

  // A rate at which the exact frame would take 15 times its budget (at 160x120 the cheapest rung, held to the 64-pixel
  // floor at step 6, is about a twentieth of the exact frame's samples).
  scene.interactive = true;
  scene.timeBudgetMs = 20;
  FrameOptions options;
  options.rateSamplesPerMs = exact.samplesEstimated / (15 * scene.timeBudgetMs);
  FrameStats stats;
  const image::ImageF frame = engine.render(dataset, scene, &stats, options);
  EXPECT_EQ(frame.width, scene.width);
  EXPECT_EQ(frame.height, scene.height);
  ASSERT_TRUE(stats.interactive.is_object());
  EXPECT_LT(stats.interactive["scale"].get<double>(), 1);
  EXPECT_LT(stats.interactive["width"].get<int>(), scene.width);
  EXPECT_LE(stats.interactive["predicted_ms"].get<double>(), scene.timeBudgetMs);
  EXPECT_LT(stats.samplesEstimated, exact.samplesEstimated / 10);
  EXPECT_LT(stats.samples, exact.samples / 4);
  // A coarse picture of the same view: close to the exact frame, not black.
  EXPECT_GT(image::compareImages(frame, full).psnr, 15);
  EXPECT_GT(test::meanBrightness(frame), 0.5 * test::meanBrightness(full));

  // At a rate that fits the exact frame, the frame is the exact one.
  options.rateSamplesPerMs = exact.samplesEstimated;
  const image::ImageF same = engine.render(dataset, scene, &stats, options);
  EXPECT_EQ(stats.interactive["rung"].get<int>(), 0);
  // The same frame within round-off (the coarser frame before moved bricks to other atlas slots).
  test::expectClose(same, full, 1e-4, "an interactive frame at a rate that fits the exact one");
}

TEST(InteractiveFrames, AFrameForASmallerVideoStreamIsDrawnAndReturnedAtItsSize) {
  ScratchDir dir;
  const auto dataset = blobs(dir);
  RenderEngine engine({});
  Scene scene = blobScene();
  FrameStats exact;
  engine.render8(dataset, scene, &exact);  // paged in
  // At 0.75 of 160x120, with a rate that fits the exact frame: the exact drawing at 120x90, nothing scaled.
  scene.interactive = true;
  scene.timeBudgetMs = 20;
  FrameOptions options;
  options.rateSamplesPerMs = exact.samplesEstimated;
  options.outputScale = 0.75;
  FrameStats stats;
  const image::Image8 smaller = engine.render8(dataset, scene, &stats, options);
  EXPECT_EQ(smaller.width, 120);
  EXPECT_EQ(smaller.height, 90);
  EXPECT_EQ(stats.interactive["rung"].get<int>(), 0);
  EXPECT_EQ(stats.interactive["width"].get<int>(), 120);
  EXPECT_LT(stats.samplesEstimated, 0.6 * exact.samplesEstimated) << "0.56 of the pixels";
  Scene small = blobScene();
  small.width = 120, small.height = 90;
  small.lod = scene.lod * 0.75;  // the level of detail of the scene's size
  const image::Image8 smallExact = engine.render8(dataset, small);
  ASSERT_EQ(smaller.rgba.size(), smallExact.rgba.size());
  EXPECT_EQ(smaller.rgba, smallExact.rgba) << "the exact frame of the scene at the stream's size";
  EXPECT_GT(test::meanBrightness(image::toImageF(smaller)), 0.01);

  // A budget the ladder meets below the stream's size: drawn smaller still, returned at the stream's size.
  options.rateSamplesPerMs = exact.samplesEstimated / (100 * scene.timeBudgetMs);
  const image::Image8 coarse = engine.render8(dataset, scene, &stats, options);
  EXPECT_EQ(coarse.width, 120);
  EXPECT_EQ(coarse.height, 90);
  EXPECT_LT(stats.interactive["width"].get<int>(), 120);
  // The float frame alike.
  EXPECT_EQ(engine.render(dataset, scene, nullptr, options).width, 120);

  // A scale outside (0, 1] is the caller's mistake, named.
  for (const double bad : {0.0, -1.0, 1.5, std::nan("")}) {
    options.outputScale = bad;
    EXPECT_THROW(engine.render8(dataset, scene, nullptr, options), RenderInputError) << bad;
  }
}

TEST(InteractiveFrames, FramesSplitForCancellationAreTheSameFrames) {
  ScratchDir dir;
  const auto store = test::prep("synthetic:blobs,n=64", dir / "blobs", 16);
  for (const char* technique : {"raycast", "slab", "slice"}) {
    Scene scene = blobScene();
    scene.raycast = std::strcmp(technique, "raycast") == 0;
    scene.slab = std::strcmp(technique, "slab") == 0 ? 8 : 0;
    const image::ImageF plain = test::renderStore(store, scene);
    FrameOptions split;
    split.cancelled = [] { return false; };
    split.checkpointSamples = 2000;  // bands of a few rows, slabs in tiles, slices in short runs
    const image::ImageF finely = test::renderStore(store, scene, nullptr, size_t(256) << 20, size_t(256) << 20, split);
    ASSERT_EQ(plain.rgba.size(), finely.rgba.size()) << technique;
    EXPECT_EQ(std::memcmp(plain.rgba.data(), finely.rgba.data(), plain.rgba.size() * sizeof(float)), 0) << technique;
    EXPECT_GT(test::meanBrightness(plain), 0.01) << technique;
  }
}

TEST(InteractiveFrames, AFrameCancelledPartWayStopsWithinItsInterval) {
  // A heavy frame (a step of 0.01 voxel) given up after its first checkpoint: it stops within about one interval's
  // work, where 64-row bands took seconds.
  // Both ray caster kernels: the compute kernel's tiles are whole workgroups of 8x8 pixels.
  ScratchDir dir;
  const auto store = test::prep("synthetic:blobs,n=64", dir / "blobs", 16);
  for (RayCaster kernel : {RayCaster::Fragment, RayCaster::Compute}) {
    Scene scene = blobScene();
    scene.width = scene.height = 256;
    scene.step = 0.01;
    scene.raycaster = kernel;
    int asked = 0;
    FrameOptions options;
    options.cancelled = [&] { return ++asked > 3; };
    options.checkpointSamples = 2e5;
    const auto start = std::chrono::steady_clock::now();
    EXPECT_THROW(test::renderStore(store, scene, nullptr, size_t(256) << 20, size_t(256) << 20, options),
                 FrameCancelled);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(ms, 1000) << rayCasterName(kernel) << ": a cancelled frame must stop within a few intervals";
  }
}

}  // namespace
}  // namespace voxbrick::render
