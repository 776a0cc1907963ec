// A frame that fails (a corrupt brick met in the middle of drawing) leaves its GL context as it found it: the same
// engine then draws other datasets exactly as a fresh one does, and the bad dataset fails again with the same clear
// error, never a GL one.
#include <gtest/gtest.h>

#include <algorithm>

#include <fstream>

#include "brickstore/format/Errors.h"
#include "render/core/Dataset.h"
#include "render/core/RenderErrors.h"
#include "render/engine/Datasets.h"
#include "render/engine/RenderEngine.h"
#include "render/gl/GlFixtures.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::ScratchDir;

/// Flips bytes in the middle of one stored brick of level 0 (the seventh in storage order), so that a frame pages
/// good bricks before it meets the bad one, and a frame that did not read it again would not fail.
void corruptBricks(const std::filesystem::path& storeDir) {
  const auto s = store::BrickStore::open(storeDir);
  std::fstream file(storeDir / "bricks.bin", std::ios::in | std::ios::out | std::ios::binary);
  ASSERT_TRUE(file.good());
  const store::LevelMeta& level = s->level(0);
  int stored = 0;
  for (uint32_t k = 0; k < uint32_t(level.bricks.z); ++k)
    for (uint32_t j = 0; j < uint32_t(level.bricks.y); ++j)
      for (uint32_t i = 0; i < uint32_t(level.bricks.x); ++i) {
        const store::BrickRecord& r = s->record({0, i, j, k});
        if (r.compressedSize < 64 || ++stored != 7) continue;
        std::vector<char> bytes(8);
        const auto at = static_cast<std::streamoff>(r.offset + r.compressedSize / 2);
        file.seekg(at);
        file.read(bytes.data(), std::streamsize(bytes.size()));
        for (char& c : bytes) c = static_cast<char>(~c);
        file.seekp(at);
        file.write(bytes.data(), std::streamsize(bytes.size()));
      }
  ASSERT_TRUE(file.good());
  ASSERT_GE(stored, 7);
}

std::string failure(RenderEngine& engine, const std::shared_ptr<const Dataset>& d, const Scene& scene) {
  try {
    engine.render(d, scene);
  } catch (const store::CorruptStoreError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not a CorruptStoreError: " << e.what();
    return e.what();
  }
  ADD_FAILURE() << "the frame of a corrupt store did not fail";
  return {};
}

TEST(FailedFrames, LeaveTheContextAsTheyFoundIt) {
  ScratchDir dir;
  test::prep("synthetic:blobs,n=64,seed=5", dir / "bad", 16);
  test::prep("synthetic:blobs,n=64,seed=6", dir / "good", 16);
  corruptBricks(dir / "bad");
  const auto bad = openDataset("bad", dir / "bad", size_t(64) << 20);
  const auto good = openDataset("good", dir / "good", size_t(64) << 20);

  // Every way a frame draws: slicing, the ray caster, the CPU slicer, out of core, after stand-ins, staged uploads,
  // slabs, the ray caster's compute kernel.
  for (int variant = 0; variant < 8; ++variant) {
    Scene s = test::lodScene(0);
    RenderEngineOptions options{Backend::Auto, size_t(64) << 20, AtlasFormat::Float};
    switch (variant) {
      case 0:
        s.slab = 0;
        s.raycast = false;
        break;
      case 1: break;
      case 2:
        s.slicer = Slicer::Cpu;
        s.slab = 0;
        s.raycast = false;
        break;
      case 3: options.gpuBudgetBytes = size_t(200) << 10; break;
      case 5: options.atlasUploads = AtlasUploads::Staged; break;
      case 6: s.raycast = false; break;
      case 7: s.raycaster = RayCaster::Compute; break;
    }
    const std::string what = "variant " + std::to_string(variant);
    image::ImageF want;
    {
      RenderEngine fresh(options);
      want = fresh.render(good, s);
      ASSERT_GT(test::meanBrightness(want), 0.01) << what;
    }
    RenderEngine engine(options);
    if (variant == 4) {
      // A provisional frame draws the bad bricks from their (sound) ancestors and queues them, which fails
      // quietly on the cache's workers; the exact frame then meets them.
      FrameStats stats;
      engine.render(bad, s, &stats, {RenderMode::Normal, true});
      EXPECT_GT(stats.bricksStandIn, 0) << what;
    }
    const std::string first = failure(engine, bad, s);
    EXPECT_NE(first.find("bricks.bin"), std::string::npos) << what << ": " << first;
    for (int round = 0; round < 2; ++round) {
      test::expectClose(engine.render(good, s), want, 0.0, what + ", a good dataset after it");
      EXPECT_EQ(failure(engine, bad, s), first) << what << ": the bad one fails again, the same way";
    }
  }
}

TEST(FailedFrames, ACancelledFrameStopsAtACheckpointAndLeavesNoTrace) {
  ScratchDir dir;
  test::prep("synthetic:blobs,n=64,seed=7", dir / "d", 16);
  const auto d = openDataset("d", dir / "d", size_t(64) << 20);
  for (const int slab : {-2, -1, 4, 0}) {  // the ray caster's compute and fragment kernels, slabs, slicing
    Scene s = test::lodScene(0);
    s.raycast = slab < 0;
    s.raycaster = slab == -2 ? RayCaster::Compute : RayCaster::Fragment;
    if (slab >= 0) s.slab = slab;
    const std::string what = slab == -2 ? "raycast compute, paced"
                             : slab < 0 ? "raycast, paced"
                             : slab > 0 ? "slabs, paced"
                                        : "slicing, paced";
    // In core: out of core, which bricks a cancelled frame left resident changes the batches, and the image by up
    // to 1/255 (as any two batchings do).
    RenderEngine engine({Backend::Auto, size_t(64) << 20, AtlasFormat::Float});
    const image::ImageF want = engine.render(d, s);
    // A warm frame's checkpoints (the ray caster's kept table asks none between bricks when they are the same).
    // Their interval is fixed here: left to the engine, it follows the rate the device drew at lately, so on a busy
    // machine the next frame could ask fewer than this one did.
    int checkpoints = 0;
    FrameOptions options;
    options.checkpointSamples = 20000;
    options.cancelled = [&] { return ++checkpoints < 0; };
    engine.render(d, s, nullptr, options);
    ASSERT_GE(checkpoints, 1) << what;
    const int giveUpAfter = std::min(5, checkpoints - 1);
    int asked = 0;
    options.cancelled = [&] { return ++asked > giveUpAfter; };
    EXPECT_THROW(engine.render(d, s, nullptr, options), FrameCancelled) << what;
    EXPECT_EQ(asked, giveUpAfter + 1) << what << ": given up at the first checkpoint that said so";
    FrameStats stats;
    options.cancelled = [] { return false; };
    test::expectClose(engine.render(d, s, &stats, options), want, 0.0, what);
    EXPECT_GT(stats.samplesEstimated, double(stats.samples)) << what << ": the cost estimate bounds the samples taken";
  }
}

TEST(FailedFrames, AComputeFrameCancelledWithinABandLeavesTheTargetToTheNextFrame) {
  // Checkpoints every few workgroups: the compute kernel's frame is given up between two of its dispatches, its
  // image stores still queued; the next frame, of either kernel, clears and draws the target as a fresh engine does.
  ScratchDir dir;
  test::prep("synthetic:blobs,n=64,seed=8", dir / "d", 16);
  const auto d = openDataset("d", dir / "d", size_t(64) << 20);
  Scene compute = test::lodScene(0), fragment = compute;
  compute.raycaster = RayCaster::Compute;
  fragment.raycaster = RayCaster::Fragment;
  image::ImageF wantCompute, wantFragment;
  {
    RenderEngine fresh({Backend::Auto, size_t(64) << 20, AtlasFormat::Float});
    wantCompute = fresh.render(d, compute);
    wantFragment = fresh.render(d, fragment);
    ASSERT_GT(test::meanBrightness(wantCompute), 0.01);
  }
  RenderEngine engine({Backend::Auto, size_t(64) << 20, AtlasFormat::Float});
  // The checkpoints of a warm frame: one a tile (the ray caster's kept table asks none between bricks that are the
  // same); the last ones are the last tiles.
  int checkpoints = 0;
  FrameOptions options;
  options.checkpointSamples = 20000;  // a few workgroups of the frame's rays a tile
  engine.render(d, compute, nullptr, options);
  options.cancelled = [&] { return ++checkpoints < 0; };
  engine.render(d, compute, nullptr, options);
  ASSERT_GT(checkpoints, 20);
  for (const Scene& next : {compute, fragment}) {
    int asked = 0;
    options.cancelled = [&] { return ++asked > checkpoints - 4; };
    EXPECT_THROW(engine.render(d, compute, nullptr, options), FrameCancelled);
    EXPECT_EQ(asked, checkpoints - 3) << "given up at the first checkpoint that said so";
    FrameStats stats;
    const image::ImageF frame = engine.render(d, next, &stats);
    test::expectClose(frame, next.raycaster == RayCaster::Compute ? wantCompute : wantFragment, 0.0,
                      std::string("after a cancelled compute frame, ") + rayCasterName(next.raycaster));
    EXPECT_EQ(stats.raycaster, rayCasterName(next.raycaster));
  }
}

}  // namespace
}  // namespace voxbrick::render
