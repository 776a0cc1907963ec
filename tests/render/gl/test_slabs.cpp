// Texture slabs against slicing: the same samples on the same global planes, composited in registers per slab and
// blended once, must give slicing's image (within 1/255) for any slab size, camera, bricking and budget.
#include <gtest/gtest.h>

#include <string>

#include "image/Image.h"
#include "render/core/RenderErrors.h"
#include "render/gl/GlFixtures.h"
#include "render/reference/ReferenceRenderer.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::expectClose;
using test::meanBrightness;
using test::prep;
using test::renderStore;
using test::ScratchDir;

/// Slicing, the baseline slabs are held to.
Scene slabSceneFor(const std::string& tf) { return test::slicingScene(tf); }

std::vector<std::pair<std::string, CameraSpec>> slabCameras() { return test::marchCameras(false); }

TEST(Slabs, EverySlabSizeGivesSlicingsImage) {
  ScratchDir dir;
  const auto s = prep("synthetic:marschner-lobb,n=40", dir / "ml", 16);
  for (const auto& [name, camera] : slabCameras()) {
    Scene scene = slabSceneFor("hot");
    scene.camera = camera;
    const image::ImageF sliced = renderStore(s, scene);
    ASSERT_GT(meanBrightness(sliced), 0.005) << name;
    for (int slab : {1, 3, 16, Scene::kMaxSlab}) {
      scene.slab = slab;
      scene.raycast = false;
      test::expectSameDrawing(renderStore(s, scene), sliced, 1.0 / 255, *s, scene,
                              "slab-" + std::to_string(slab) + "-" + name);
    }
  }
}

TEST(Slabs, ShadingSubBlocksAndSparseData) {
  ScratchDir dir;
  const auto s = prep("synthetic:sparse,n=96", dir / "s", 16);
  Scene scene = slabSceneFor("sparse");
  scene.shading = true;
  const image::ImageF sliced = renderStore(s, scene);
  ASSERT_GT(meanBrightness(sliced), 0.001);
  for (int subBlock : {0, 4}) {
    scene.subBlock = subBlock;
    scene.slab = 8;
    scene.raycast = false;
    test::expectSameDrawing(renderStore(s, scene), sliced, 1.0 / 255, *s, scene,
                            "slab-8-shaded-sub" + std::to_string(subBlock));
  }
}

TEST(Slabs, OutOfCoreEqualsInCoreAndFewerFragmentsForLargerSlabs) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=48", dir / "b", 8);
  Scene scene = slabSceneFor("hot");
  FrameStats one, four, whole, tight;
  scene.slab = 1;
  scene.raycast = false;
  const image::ImageF roomy = renderStore(s, scene, &one);
  scene.slab = 4;
  scene.raycast = false;
  const image::ImageF byFour = renderStore(s, scene, &four);
  scene.slab = Scene::kMaxSlab;
  scene.raycast = false;
  const image::ImageF wholeBricks = renderStore(s, scene, &whole);
  // A budget of a few bricks: many batches, bricks evicted and paged again.
  const image::ImageF paged =
      renderStore(s, scene, &tight, size_t(10) * 10 * 10 * 4 * 6, size_t(256) << 20, test::batched());
  EXPECT_GT(tight.batches, 5);
  expectClose(paged, wholeBricks, 1.0 / 255, "slab-out-of-core");
  expectClose(byFour, roomy, 1.0 / 255, "slab-4-vs-1");
  expectClose(wholeBricks, roomy, 1.0 / 255, "slab-whole-vs-1");
  // A fragment carries up to N samples: fewer fragments as slabs grow.
  EXPECT_LT(four.fragments * 2, one.fragments);
  EXPECT_LT(whole.fragments, four.fragments);
  EXPECT_EQ(whole.bricksDrawn, one.bricksDrawn);
}

/// An opaque scene: most rays reach full opacity within a few voxels.
Scene opaqueScene() {
  Scene scene = slabSceneFor("hot");
  scene.transferFunction = TransferFunction::parse(
      R"({"points": [[0, 0, 0, 0, 0], [0.04, 0, 0, 0, 0], [0.08, 1, 0.6, 0.3, 0.9], [1, 1, 1, 1, 1]]})", "opaque");
  scene.width = 128;
  scene.height = 112;
  return scene;
}

TEST(Slabs, EarlyRayTerminationStaysWithinItsBoundAndSkipsWork) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=64", dir / "b", 16);
  Scene scene = opaqueScene();
  scene.slab = 16;
  scene.raycast = false;
  scene.subBlock = 4;  // so that most samples lie where rays can terminate
  FrameStats full, cut;
  const image::ImageF reference = renderStore(s, scene, &full);
  ASSERT_GT(meanBrightness(reference), 0.05);
  EXPECT_EQ(full.samplesTerminated, 0);
  for (double ert : {0.9, 0.99}) {
    scene.ert = ert;
    const image::ImageF terminated = renderStore(s, scene, &cut);
    // What a terminated ray leaves out is at most its remaining transmittance, 1 - ert, in every channel.
    expectClose(terminated, reference, (1 - ert) + 1.0 / 255, "ert-" + std::to_string(ert));
    EXPECT_LT(cut.fragments * 10, full.fragments * 7) << "the silhouette map rejects terminated pixels";
    EXPECT_LT(cut.samples * 2, full.samples) << ert;
    EXPECT_GT(cut.samplesTerminated, 0) << "fragments stop marching too";
  }
  // Off on slicing: no slabs to put a silhouette map between.
  scene.slab = 0;
  scene.raycast = false;
  scene.ert = 0.9;
  expectClose(renderStore(s, scene), reference, 1.0 / 255, "ert-ignored-when-slicing");
}

TEST(Slabs, EarlyRayTerminationOutOfCoreAndInside) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=48", dir / "b", 8);
  Scene scene = opaqueScene();
  scene.slab = 2;
  scene.raycast = false;
  const double ert = 0.95;
  for (const auto& [name, camera] : slabCameras()) {
    scene.camera = camera;
    scene.ert = 0;
    const image::ImageF reference = renderStore(s, scene);
    scene.ert = ert;
    FrameStats tight;
    expectClose(renderStore(s, scene), reference, (1 - ert) + 1.0 / 255, "ert-in-core-" + name);
    const image::ImageF paged =
        renderStore(s, scene, &tight, size_t(10) * 10 * 10 * 4 * 6, size_t(256) << 20, test::batched());
    EXPECT_GT(tight.batches, 5) << name;
    expectClose(paged, reference, (1 - ert) + 1.0 / 255, "ert-out-of-core-" + name);
  }
}

TEST(Slabs, SlabsTakeSlicingsSamples) {
  ScratchDir dir;
  const auto s = prep("synthetic:marschner-lobb,n=40", dir / "ml", 16);
  Scene scene = slabSceneFor("hot");
  FrameStats sliced, slabbed;
  renderStore(s, scene, &sliced);
  scene.slab = 5;
  scene.raycast = false;
  renderStore(s, scene, &slabbed);
  EXPECT_EQ(sliced.samples, sliced.fragments);
  EXPECT_NEAR(double(slabbed.samples), double(sliced.samples), 0.01 * double(sliced.samples));
  EXPECT_LT(slabbed.fragments * 2, sliced.fragments) << "several samples a fragment";
  EXPECT_GT(slabbed.slabPasses, 5);
}

// Pre-integration classifies each segment as if the value ran linearly between its two samples. Where the transfer
// function is sharper than the field (a thin iso-shell), point samples step over it and the table does not; where
// both are smooth, linear interpolation is the trapezoid rule against post-classification's midpoint rule, about
// twice its error, and both converge to the reference.
TEST(Slabs, PreIntegrationCatchesWhatSamplesStepOverAndConverges) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=48", dir / "b", 16);
  ReferenceOptions options;
  options.step = 0.125;
  Scene scene = slabSceneFor("ct-bone");
  scene.transferFunction = TransferFunction::parse(
      R"({"points": [[0, 0, 0, 0, 0], [0.3, 0, 0, 0, 0], [0.31, 1, 0.8, 0.5, 0.8], [0.32, 0, 0, 0, 0],
                     [1, 0, 0, 0, 0]]})",
      "shell");
  const image::ImageF shell = test::renderReference(s, scene, options);
  ASSERT_GT(meanBrightness(shell), 0.005);
  scene.slab = 16;
  scene.raycast = false;
  for (double step : {0.5, 2.0}) {
    scene.step = step;
    scene.preIntegration = false;
    const image::ImageError post = image::compareImages(renderStore(s, scene), shell);
    scene.preIntegration = true;
    const image::ImageError pre = image::compareImages(renderStore(s, scene), shell);
    std::printf("thin shell, step %.1f: post-classified %.1f dB, pre-integrated %.1f dB\n", step, post.psnr, pre.psnr);
    EXPECT_GT(pre.psnr, post.psnr + 8) << "step " << step;
  }

  scene = slabSceneFor("ct-bone");
  const image::ImageF bone = test::renderReference(s, scene, options);
  scene.slab = 16;
  scene.raycast = false;
  scene.preIntegration = true;
  scene.step = 0.25;
  const image::ImageError fine = image::compareImages(renderStore(s, scene), bone);
  scene.step = 1;
  const image::ImageError coarse = image::compareImages(renderStore(s, scene), bone);
  std::printf("ct-bone, pre-integrated: step 0.25 %.1f dB, step 1 %.1f dB\n", fine.psnr, coarse.psnr);
  EXPECT_GT(fine.psnr, 60);
  EXPECT_GT(fine.psnr, coarse.psnr + 8);

  // The image does not depend on the slab size; shading and termination work with it.
  const image::ImageF sixteen = renderStore(s, scene);
  scene.slab = 1;
  scene.raycast = false;
  expectClose(renderStore(s, scene), sixteen, 1.0 / 255, "pre-int-slab-1");
  scene.slab = Scene::kMaxSlab;
  scene.raycast = false;
  expectClose(renderStore(s, scene), sixteen, 1.0 / 255, "pre-int-slab-whole");
  scene.ert = 0.99;
  expectClose(renderStore(s, scene), sixteen, 0.01 + 1.0 / 255, "pre-int-ert");
  scene.shading = true;
  EXPECT_GT(meanBrightness(renderStore(s, scene)), 0.005) << "shaded, terminated, pre-integrated";
}

// The empty-space silhouette pass marks the pixels a slab has anything to draw for; the march skips the rest. The
// image must not change: a skipped pixel's samples were all transparent.
TEST(Slabs, EmptySpaceMapsSkipEmptyPixelsAndChangeNothing) {
  ScratchDir dir;
  const auto s = prep("synthetic:sparse,n=96", dir / "s", 32);
  for (bool preIntegration : {false, true})
    for (double ert : {0.0, 0.999}) {
      Scene scene = slabSceneFor("sparse");
      scene.slab = 8;
      scene.raycast = false;
      scene.ert = ert;
      scene.preIntegration = preIntegration;
      FrameStats plain, mapped;
      const image::ImageF without = renderStore(s, scene, &plain);
      ASSERT_GT(meanBrightness(without), 0.001);
      scene.ess = true;
      const std::string what = "ess-ert" + std::to_string(ert) + (preIntegration ? "-pre-int" : "");
      test::expectSameDrawing(renderStore(s, scene, &mapped), without, 1.0 / 255, *s, scene, what);
      EXPECT_LT(mapped.fragments * 2, plain.fragments) << what << ": empty pixels are not marched";
      EXPECT_LT(mapped.samples, plain.samples) << what;
      // Out of core: the slab counter (and so the depths) carries on across batches.
      FrameStats tight;
      test::expectSameDrawing(
          renderStore(s, scene, &tight, size_t(34) * 34 * 34 * 4 * 3, size_t(256) << 20, test::batched()), without,
          1.0 / 255 + 2 * (1 - ert), *s, scene, what + "-out-of-core");
      EXPECT_GT(tight.batches, 3) << what;
    }
  // With the eye inside the volume, and a thin shell that pre-integration finds between samples.
  Scene scene = slabSceneFor("sparse");
  scene.camera.distance = 0.25;
  scene.camera.fovY = 75;
  scene.slab = 4;
  scene.raycast = false;
  const image::ImageF inside = renderStore(s, scene);
  scene.ess = true;
  expectClose(renderStore(s, scene), inside, 1.0 / 255, "ess-inside");
  EXPECT_TRUE(Scene::fromJson(R"({"ess": true})", "t").ess);
  EXPECT_FALSE(Scene::fromJson("{}", "t").ess);
}

TEST(Slabs, TheSceneKeyIsChecked) {
  EXPECT_EQ(Scene::fromJson(R"({"slab": 16})", "t").slab, 16);
  // The default, the fastest setting that keeps every swept dataset at 40 dB: the ray caster, termination at 0.999,
  // sub-blocks of 8 voxels; slabs of 32 planes where it falls back to slabs.
  EXPECT_EQ(Scene::fromJson("{}", "t").slab, 32);
  EXPECT_EQ(Scene::fromJson("{}", "t").ert, 0.999);
  EXPECT_EQ(Scene::fromJson("{}", "t").subBlock, 8);
  EXPECT_EQ(Scene::fromJson(R"({"slab": 0})", "t").slab, 0) << "slicing on request";
  for (const char* bad : {R"({"slab": -1})", R"({"slab": 2.5})", R"({"slab": 5000})", R"({"slab": "4"})"})
    EXPECT_THROW(Scene::fromJson(bad, "t"), RenderInputError) << bad;
  Scene scene;
  scene.slab = 7;
  scene.raycast = false;
  scene.ert = 0.98;
  EXPECT_EQ(Scene::fromJson(scene.toJson(), "t").slab, 7) << "toJson keeps it";
  EXPECT_EQ(Scene::fromJson(scene.toJson(), "t").ert, 0.98);
  scene.preIntegration = true;
  EXPECT_TRUE(Scene::fromJson(scene.toJson(), "t").preIntegration);
  EXPECT_FALSE(Scene::fromJson("{}", "t").preIntegration);
  EXPECT_THROW(Scene::fromJson(R"({"pre_integration": 1})", "t"), RenderInputError);
  EXPECT_EQ(Scene::fromJson(R"({"ert": 0.995})", "t").ert, 0.995);
  for (const char* bad : {R"({"ert": 0.3})", R"({"ert": 1.5})", R"({"ert": -0.1})", R"({"ert": "high"})"})
    EXPECT_THROW(Scene::fromJson(bad, "t"), RenderInputError) << bad;
}

}  // namespace
}  // namespace voxbrick::render
