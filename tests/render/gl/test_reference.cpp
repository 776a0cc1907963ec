// The reference renderer: its own convergence, exactness where the integral is known in closed form, independence
// of bricking and skipping, the analytic sampler, and the GPU renderer converging towards it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "render/core/RenderErrors.h"
#include "render/gl/GlFixtures.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::meanBrightness;
using test::prep;
using test::prepArray;
using test::renderReference;
using test::renderStore;
using test::ScratchDir;

Scene smallReferenceScene(const std::string& tf, int size = 64) {
  Scene scene;
  scene.width = scene.height = size;
  scene.camera.azimuth = 35;
  scene.camera.elevation = 25;
  scene.camera.distance = 2.2;
  scene.camera.upAxis = UpAxis::PosY;  // the view the convergence bounds were measured on (the orbit was Y-up)
  scene.transferFunction = TransferFunction::load(tf);
  return scene;
}

ReferenceOptions withStep(double step) {
  ReferenceOptions options;
  options.step = step;
  return options;
}

// The bounds the reference proves for itself: halving its default step (1/8 voxel) moves no pixel by more than
// these, far below the error it judges (the benchmark's 40 dB is an RMSE of 1e-2). Shading converges more slowly:
// the trilinear gradient jumps across cell faces and the specular term (a 32nd power) magnifies the jumps.
constexpr double kConvergenceBound = 1e-3;
constexpr double kShadedConvergenceBound = 4e-3;
constexpr double kConvergenceRmse = 5e-4;

TEST(ReferenceConvergence, HalvingTheDefaultStepMovesNoPixelByMoreThanTheBound) {
  ScratchDir dir;
  auto s = prep("synthetic:marschner-lobb,n=32", dir / "ml", 16);
  for (bool shading : {false, true}) {
    Scene scene = smallReferenceScene("hot");
    scene.shading = shading;
    const image::ImageF coarse = renderReference(s, scene, withStep(0.125));
    const image::ImageF fine = renderReference(s, scene, withStep(0.0625));
    ASSERT_GT(meanBrightness(fine), 0.05);
    const image::ImageError e = image::compareImages(coarse, fine);
    EXPECT_LT(e.maxAbs, shading ? kShadedConvergenceBound : kConvergenceBound) << "shading " << shading;
    EXPECT_LT(e.rmse, kConvergenceRmse) << "shading " << shading;
    // The composite midpoint rule is second order where the integrand is smooth: a step four times coarser moves
    // the image by clearly more (so the bound above is not met by accident).
    const image::ImageError rough = image::compareImages(renderReference(s, scene, withStep(0.5)), fine);
    EXPECT_GT(rough.maxAbs, 2 * e.maxAbs) << "shading " << shading;
    std::printf("reference, shading %d: step 1/8 vs 1/16: max |diff| %.3g, PSNR %.1f dB; step 1/2 vs 1/16: %.3g\n",
                int(shading), e.maxAbs, e.psnr, rough.maxAbs);
  }
}

TEST(ReferenceConvergence, AStepInTheTransferFunctionConvergesToo) {
  // The sparse preset jumps from alpha 0 to 0.15 at 0.02: the reference cuts the intervals where a ray crosses it.
  // What is left are rays that graze a ball, rising above the step and falling back between two samples: a few
  // pixels, hence a looser max than for smooth transfer functions but the same RMSE bound.
  ScratchDir dir;
  auto s = prep("synthetic:sparse,n=40", dir / "sparse", 16);
  const Scene scene = smallReferenceScene("sparse");
  const image::ImageF fine = renderReference(s, scene, withStep(0.0625));
  ASSERT_GT(meanBrightness(fine), 0.005);
  const image::ImageError e = image::compareImages(renderReference(s, scene, withStep(0.125)), fine);
  std::printf("reference, sparse preset: step 1/8 vs 1/16: max |diff| %.3g, PSNR %.1f dB\n", e.maxAbs, e.psnr);
  EXPECT_LT(e.rmse, kConvergenceRmse);
  EXPECT_LT(e.maxAbs, 1e-2);
}

TEST(ReferenceExact, ConstantSlabMatchesTheClosedFormForAnyStep) {
  ScratchDir dir;
  const store::Vec3i n{16, 16, 64};
  auto s = prepArray(n, store::ValueType::F32, std::vector<float>(size_t(n.volume()), 1.0f), dir / "slab", 16);
  const double alpha = 0.05;  // per reference length (one voxel)
  Scene scene;
  scene.width = scene.height = 16;
  scene.transferFunction = TransferFunction({{0.0, {1, 1, 1, alpha}}, {1.0, {1, 1, 1, alpha}}});
  scene.camera.orbit = false;
  scene.camera.eye = {0, 0, 200};
  scene.camera.orthographic = true;
  scene.camera.fovY = 2;
  scene.background = {0, 0, 1};
  // For a constant field the product of the segments' transmittances is exactly (1 - alpha)^(L / L_ref).
  const double opacity = 1 - std::pow(1 - alpha, 64.0);
  for (double step : {0.37, 1.0, 3.0, 50.0}) {
    const image::ImageF image = renderReference(s, scene, withStep(step));
    for (int y = 0; y < scene.height; y += 5)
      for (int x = 0; x < scene.width; x += 5) {
        ASSERT_NEAR(image.pixel(x, y)[0], opacity, 1e-6) << "step " << step;
        ASSERT_NEAR(image.pixel(x, y)[2], 1.0, 1e-6) << "white emission over blue: blue stays 1";
      }
  }
}

TEST(ReferenceStore, BrickSizeAndSkippingDoNotChangeTheImage) {
  ScratchDir dir;
  Scene scene = smallReferenceScene("sparse");
  scene.shading = true;
  ReferenceStats skipping, full;
  const image::ImageF base = renderReference(prep("synthetic:sparse,n=40", dir / "s32", 32), scene);
  ASSERT_GT(meanBrightness(base), 0.005);
  for (int brick : {16, 8}) {
    auto s = prep("synthetic:sparse,n=40", dir / ("s" + std::to_string(brick)), brick);
    EXPECT_EQ(image::compareImages(renderReference(s, scene, {}, &skipping), base).maxAbs, 0) << "brick " << brick;
    scene.skipEmpty = false;
    EXPECT_EQ(image::compareImages(renderReference(s, scene, {}, &full), base).maxAbs, 0) << "brick " << brick;
    scene.skipEmpty = true;
  }
  EXPECT_GT(skipping.bricksSkipped, 0);
  EXPECT_EQ(full.bricksSkipped, 0);
  EXPECT_LT(skipping.samples * 2, full.samples) << "8-voxel bricks should spare most samples of a sparse field";
}

TEST(ReferenceAnalytic, SeparatesReconstructionFromIntegrationError) {
  ScratchDir dir;
  auto s = prep("synthetic:marschner-lobb,n=32", dir / "ml", 16);
  const Scene scene = smallReferenceScene("hot");
  ReferenceOptions analytic;
  analytic.analytic = analyticFieldFor(s->meta(), "marschner-lobb");
  const image::ImageF exact = renderReference(s, scene, analytic);
  analytic.step = 0.0625;
  const image::ImageError integration = image::compareImages(exact, renderReference(s, scene, analytic));
  const image::ImageError reconstruction = image::compareImages(exact, renderReference(s, scene));
  std::printf(
      "Marschner-Lobb 32^3: reconstruction (trilinear vs analytic) %.1f dB, max %.3g; integration "
      "(step 1/8 vs 1/16, analytic) max %.3g\n",
      reconstruction.psnr, reconstruction.maxAbs, integration.maxAbs);
  EXPECT_LT(integration.maxAbs, kConvergenceBound);
  // Marschner-Lobb at 32^3 is under-sampled on purpose: trilinear reconstruction dominates the error by far.
  EXPECT_GT(reconstruction.maxAbs, 20 * integration.maxAbs);

  EXPECT_THROW(analyticFieldFor(s->meta(), "shells"), RenderInputError);
  EXPECT_THROW(analyticFieldFor(s->meta(), "marschner-lobb,n=16"), RenderInputError);
  auto array = prepArray({4, 4, 4}, store::ValueType::F32, std::vector<float>(64, 1.0f), dir / "array", 8);
  EXPECT_THROW(analyticFieldFor(array->meta(), "marschner-lobb"), RenderInputError);
}

TEST(ReferenceVsGpu, GpuConvergesTowardsTheReference) {
  ScratchDir dir;
  auto s = prep("synthetic:marschner-lobb,n=32", dir / "ml", 16);
  Scene scene = smallReferenceScene("hot");
  const image::ImageF reference = renderReference(s, scene);
  // The default drawing, the ray caster, with each of its kernels.
  for (RayCaster kernel : {RayCaster::Fragment, RayCaster::Compute}) {
    scene.raycaster = kernel;
    double previous = 0;
    for (double step : {1.0, 0.5, 0.25}) {
      scene.step = step;
      FrameStats stats;
      const image::ImageError e = image::compareImages(renderStore(s, scene, &stats), reference);
      std::printf("GPU (%s ray caster) step %.2f vs reference: PSNR %.1f dB, max |diff| %.3g\n",
                  rayCasterName(kernel), step, e.psnr, e.maxAbs);
      EXPECT_EQ(stats.raycaster, rayCasterName(kernel));
      EXPECT_GT(e.psnr, previous) << rayCasterName(kernel) << ": a finer GPU step should come closer to the reference";
      previous = e.psnr;
    }
    EXPECT_GT(previous, 45.0) << rayCasterName(kernel);
  }
}

TEST(ReferenceCli, RendersWithTheReferenceBackend) {
  ScratchDir dir;
  auto r = test::runVoxbrick("prep synthetic:marschner-lobb,n=24 --brick 8 -q -o " + (dir / "s").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const std::string common = "render " + (dir / "s").string() + " --size 40x30 --backend reference ";
  r = test::runVoxbrick(common + "-o " + (dir / "grid.png").string() + " --reference-step 0.25");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("reference"), std::string::npos) << r.output;
  r = test::runVoxbrick(common + "-o " + (dir / "exact.png").string() + " --analytic marschner-lobb");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("analytic"), std::string::npos) << r.output;
  EXPECT_EQ(image::readPng(dir / "grid.png").width, 40);
  EXPECT_EQ(image::readPng(dir / "exact.png").height, 30);

  r = test::runVoxbrick(common + "-o " + (dir / "bad.png").string() + " --analytic shells");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("not from synthetic:shells"), std::string::npos) << r.output;
  r = test::runVoxbrick(common + "-o " + (dir / "bad.png").string() + " --reference-step 0");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("step"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace voxbrick::render
