// The renderer end to end on llvmpipe: seams between bricks, out-of-core paging, empty-space skipping, the two
// slicers, and an analytic slab whose transmittance is known in closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "render/core/RenderErrors.h"
#include "render/gl/GlFixtures.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::context;
using test::expectClose;
using test::meanBrightness;
using test::prep;
using test::prepArray;
using test::renderStore;
using test::ScratchDir;

/// Slicing: these seams are the slicer's (tests/render/test_slabs.cpp holds slabs to the same images).
Scene baseScene() {
  Scene scene;
  scene.slab = 0;
  scene.raycast = false;
  scene.ert = 0;
  scene.subBlock = 0;
  scene.width = scene.height = 96;
  scene.camera.azimuth = 35;
  scene.camera.elevation = 25;
  scene.camera.distance = 2.2;
  scene.transferFunction = TransferFunction::load("hot");
  scene.step = 0.5;
  return scene;
}

/// `scene` drawn as the default draws: the frame ray caster with termination and sub-blocks.
Scene defaultDrawing(Scene scene) {
  const Scene defaults;
  scene.raycast = defaults.raycast;
  scene.slab = defaults.slab;
  scene.ert = defaults.ert;
  scene.subBlock = defaults.subBlock;
  return scene;
}

/// How far two frames that may each differ from the full integral by termination can be apart, beyond 1/255.
double terminationSlack(const Scene& scene) { return scene.slab > 0 && scene.ert > 0 ? 2 * (1 - scene.ert) : 0; }

TEST(RendererSeams, BrickSizesGiveTheSameImage) {
  ScratchDir dir;
  std::vector<std::shared_ptr<const store::BrickStore>> stores;
  for (int brick : {64, 8, 16, 32}) stores.push_back(prep("synthetic:blobs,n=60", dir / std::to_string(brick), brick));
  // An oblique view, and views along an axis and a diagonal, where planes run through brick faces and corners.
  for (glm::dvec2 view : {glm::dvec2(35, 25), glm::dvec2(0, 0), glm::dvec2(90, 0), glm::dvec2(45, 35.2643897)})
    for (const Scene& drawing : {baseScene(), defaultDrawing(baseScene())}) {
      Scene scene = drawing;
      scene.camera.azimuth = view.x;
      scene.camera.elevation = view.y;
      const image::ImageF whole = renderStore(stores[0], scene);
      ASSERT_GT(meanBrightness(whole), 0.02) << "the reference frame is empty; the test would prove nothing";
      for (size_t i = 1; i < stores.size(); ++i) {
        FrameStats stats;
        const image::ImageF bricked = renderStore(stores[i], scene, &stats);
        EXPECT_GT(stats.bricksDrawn, 1);
        expectClose(bricked, whole, 1.0 / 255 + terminationSlack(scene),
                    "seams-" + std::to_string(stores[i]->brickSize()) + "-az" + std::to_string(int(view.x)) + "-slab" +
                        std::to_string(scene.slab));
      }
    }
}

TEST(RendererOutOfCore, TinyBudgetsGiveTheSameImage) {
  ScratchDir dir;
  auto s = prep("synthetic:marschner-lobb,n=48", dir / "s", 8);
  Scene scene = baseScene();
  scene.transferFunction = TransferFunction::load("grayscale");
  FrameStats roomy, tight;
  const image::ImageF reference = renderStore(s, scene, &roomy);
  const size_t brickBytes = s->brickBytes() * sizeof(float) / store::valueSize(s->type());
  // Three atlas slots and a host cache smaller than the volume's decoded bricks.
  const image::ImageF small = renderStore(s, scene, &tight, 3 * brickBytes, s->brickBytes() * 5, test::batched());
  EXPECT_EQ(roomy.batches, 1);
  EXPECT_GT(tight.batches, 10);
  EXPECT_GT(tight.bricksEvicted, 0);
  // Not bit-identical: slots sit elsewhere in a differently sized atlas, so texel coordinates round differently.
  test::expectSameDrawing(small, reference, 1e-4, *s, scene, "out-of-core");
}

TEST(RendererSkipping, SameImageWithFarFewerBricksOnASparseField) {
  ScratchDir dir;
  auto s = prep("synthetic:sparse,n=96", dir / "s", 16);
  for (const Scene& drawing : {baseScene(), defaultDrawing(baseScene())}) {
    Scene scene = drawing;
    scene.transferFunction = TransferFunction::load("sparse");
    FrameStats skipped, full;
    const image::ImageF a = renderStore(s, scene, &skipped);
    scene.skipEmpty = false;
    const image::ImageF b = renderStore(s, scene, &full);
    ASSERT_GT(meanBrightness(a), 0.001);
    test::expectSameDrawing(a, b, 1.0 / 255 + terminationSlack(scene), *s, scene,
                            "skipping-slab" + std::to_string(scene.slab));
    EXPECT_EQ(full.bricksSkippedEmpty, 0);
    EXPECT_GT(skipped.bricksSkippedEmpty, 0);
    EXPECT_LT(skipped.bricksDrawn * 3, full.bricksDrawn) << "skipping should draw far fewer bricks";
    EXPECT_LT(skipped.bricksPagedIn * 3, full.bricksPagedIn);
  }
}

TEST(RendererSkipping, NeverDropsWhatTheTransferTableWouldDraw) {
  // Half the volume sits just below the sparse preset's step at 0.02: exactly transparent for the piecewise-linear
  // function, but the GPU's filtered table gives it some opacity. Skipping must keep those bricks.
  ScratchDir dir;
  const store::Vec3i n{32, 32, 32};
  std::vector<float> values(size_t(n.volume()), 0.0f);
  for (int64_t z = 0; z < n.z; ++z)
    for (int64_t y = 0; y < n.y; ++y)
      for (int64_t x = 0; x < 16; ++x) values[size_t(x + n.x * (y + n.y * z))] = 0.01998f;
  auto s = prepArray(n, store::ValueType::F32, values, dir / "s", 8);
  for (const Scene& drawing : {baseScene(), defaultDrawing(baseScene())}) {
    Scene scene = drawing;
    scene.transferFunction = TransferFunction::load("sparse");
    scene.window = std::array<double, 2>{0.0, 1.0};
    const image::ImageF skipped = renderStore(s, scene);
    scene.skipEmpty = false;
    const image::ImageF full = renderStore(s, scene);
    ASSERT_GT(meanBrightness(full), 0.01) << "the near-step values should be visible";
    expectClose(skipped, full, 1.0 / 255 + terminationSlack(scene), "skipping-table-slab" + std::to_string(scene.slab));
  }
}

TEST(RendererSubBlocks, SameImageWithFewerSamples) {
  // Sub-blocks of 4 and 8 voxels inside bricks of 16, merged where all contribute: boxes of several sizes meet at
  // T-junctions, where rasterised edges alone would leave cracks or double samples. Both slicers.
  ScratchDir dir;
  auto s = prep("synthetic:sparse,n=96", dir / "s", 16);
  Scene scene = baseScene();
  scene.width = scene.height = 192;
  scene.transferFunction = TransferFunction::load("sparse");
  for (Slicer slicer : {Slicer::Vertex, Slicer::Cpu}) {
    scene.slicer = slicer;
    scene.subBlock = 0;
    FrameStats whole;
    const image::ImageF reference = renderStore(s, scene, &whole);
    ASSERT_GT(meanBrightness(reference), 0.001);
    EXPECT_EQ(whole.subBlocksSkipped, 0);
    EXPECT_EQ(whole.boxesDrawn, whole.bricksDrawn);
    for (int subBlock : {8, 4}) {
      scene.subBlock = subBlock;
      FrameStats stats;
      const image::ImageF image = renderStore(s, scene, &stats);
      const std::string what = "sub-block-" + std::to_string(subBlock) + (slicer == Slicer::Cpu ? "-cpu" : "");
      test::expectSameDrawing(image, reference, 1.0 / 255, *s, scene, what);
      EXPECT_EQ(stats.bricksDrawn, whole.bricksDrawn) << what;
      EXPECT_GT(stats.subBlocksSkipped, 0) << what;
      EXPECT_GT(stats.boxesDrawn, stats.bricksDrawn) << what;
      EXPECT_LT(stats.fragments * 10, whole.fragments * 8) << what << ": sub-blocks should save samples";
    }
  }
}

TEST(RendererSlicers, VertexProgramAndCpuSlicerAgree) {
  ScratchDir dir;
  auto s = prep("synthetic:shells,n=40", dir / "s", 16);
  Scene scene = baseScene();
  const image::ImageF gpu = renderStore(s, scene);
  scene.slicer = Slicer::Cpu;
  const image::ImageF cpu = renderStore(s, scene);
  ASSERT_GT(meanBrightness(gpu), 0.01);
  expectClose(gpu, cpu, 1.0 / 255, "slicers");
}

TEST(RendererSlicers, ZellmannVariantsDrawTheVertexProgramsFrame) {
  // Vertex-lean, geometry and vertex-geometry against the vertex program: an oblique view, views along an axis and
  // a diagonal (planes through brick faces, edges and corners), the eye inside the volume, orthographic, and with
  // sub-blocks (boxes of several sizes, exact ownership) and a GPU budget of a few bricks.
  ScratchDir dir;
  auto s = prep("synthetic:shells,n=40", dir / "s", 16);
  struct View {
    const char* name;
    double azimuth, elevation, distance;
    bool orthographic;
    int subBlock;
    size_t gpuBudget;
  };
  const size_t brickBytes = s->brickBytes() * sizeof(float) / store::valueSize(s->type());
  const std::vector<View> views = {{"oblique", 35, 25, 2.2, false, 0, size_t(256) << 20},
                                   {"axis", 0, 0, 2.2, false, 0, size_t(256) << 20},
                                   {"diagonal", 45, 35.2643897, 2.2, true, 0, size_t(256) << 20},
                                   {"inside", 20, 10, 0.3, false, 0, size_t(256) << 20},
                                   {"sub-blocks", 35, 25, 2.2, false, 4, size_t(256) << 20},
                                   {"out-of-core", 110, -30, 2.2, false, 0, 5 * brickBytes}};
  for (const View& view : views) {
    Scene scene = baseScene();
    scene.camera.azimuth = view.azimuth;
    scene.camera.elevation = view.elevation;
    scene.camera.distance = view.distance;
    scene.camera.orthographic = view.orthographic;
    scene.subBlock = view.subBlock;
    const image::ImageF vertex = renderStore(s, scene, nullptr, view.gpuBudget, size_t(256) << 20, test::batched());
    ASSERT_GT(meanBrightness(vertex), 0.005) << view.name;
    for (Slicer slicer : {Slicer::VertexLean, Slicer::Geometry, Slicer::VertexGeometry}) {
      scene.slicer = slicer;
      FrameStats stats;
      const image::ImageF frame = renderStore(s, scene, &stats, view.gpuBudget, size_t(256) << 20, test::batched());
      const std::string what = std::string("slicer-") + slicerName(slicer) + "-" + view.name;
      test::expectSameDrawing(frame, vertex, 1.0 / 255, *s, scene, what);
      EXPECT_GT(stats.slices, 0) << what;
      if (view.gpuBudget < brickBytes * 8) {
        EXPECT_GT(stats.batches, 2) << what << ": not out of core";
      }
      std::printf("[ info ] %s: max |diff| %.3g against the vertex program\n", what.c_str(),
                  image::compareImages(frame, vertex).maxAbs);
    }
  }
}

TEST(RendererSlicers, SlicerDoesNotApplyToSlabsOrTheRayCaster) {
  // Texture slabs and the ray caster draw box proxies whatever the slicer: the same frame bit for bit.
  ScratchDir dir;
  auto s = prep("synthetic:shells,n=40", dir / "s", 16);
  for (bool raycast : {false, true}) {
    Scene scene = defaultDrawing(baseScene());
    scene.raycast = raycast;
    const image::ImageF vertex = renderStore(s, scene);
    ASSERT_GT(meanBrightness(vertex), 0.005);
    for (Slicer slicer : {Slicer::Cpu, Slicer::VertexLean, Slicer::Geometry, Slicer::VertexGeometry}) {
      scene.slicer = slicer;
      expectClose(renderStore(s, scene), vertex, 0, std::string(raycast ? "raycast-" : "slabs-") + slicerName(slicer));
    }
  }
}

TEST(RendererSlicers, PointsModeDrawsOnlyTheCornersOfSlices) {
  // The benchmark's points mode (RenderMode::Points): the same slices, a small part of the fragments, and the
  // context back to filled polygons for the next frame. Slicing only.
  ScratchDir dir;
  auto s = prep("synthetic:shells,n=40", dir / "s", 16);
  auto cache = std::make_shared<store::BrickCache>(s, size_t(256) << 20, 1);
  VolumeRenderer renderer(context(), cache, size_t(256) << 20);
  Scene scene = baseScene();
  for (Slicer slicer : kSlicers) {
    scene.slicer = slicer;
    FrameStats blending, points, after;
    const image::ImageF reference = renderer.render(scene, &blending);
    renderer.render(scene, &points, {RenderMode::Points});
    const image::ImageF again = renderer.render(scene, &after);
    EXPECT_EQ(points.slices, blending.slices) << slicerName(slicer);
    EXPECT_GT(points.fragments, 0) << slicerName(slicer);
    EXPECT_LT(points.fragments * 4, blending.fragments) << slicerName(slicer);
    expectClose(again, reference, 0, std::string("points-then-blending-") + slicerName(slicer));
  }
  scene.slab = 8;
  EXPECT_THROW(renderer.render(scene, nullptr, {RenderMode::Points}), RenderInputError) << "slabs";
  scene.raycast = true;
  EXPECT_THROW(renderer.render(scene, nullptr, {RenderMode::Points}), RenderInputError) << "the ray caster";
}

TEST(RendererAnalytic, ConstantSlabHasClosedFormTransmittance) {
  ScratchDir dir;
  const store::Vec3i n{16, 16, 64};
  auto s = prepArray(n, store::ValueType::F32, std::vector<float>(size_t(n.volume()), 1.0f), dir / "slab", 16);

  const double alpha = 0.05;  // opacity per reference length (one voxel)
  Scene scene;
  scene.width = scene.height = 32;
  scene.transferFunction = TransferFunction({{0.0, {1, 1, 1, alpha}}, {1.0, {1, 1, 1, alpha}}});
  scene.camera.orbit = false;
  scene.camera.eye = {0, 0, 200};
  scene.camera.center = {0, 0, 0};
  scene.camera.orthographic = true;
  scene.camera.fovY = 2;  // a view about 7 voxels high: every pixel looks through the full 64 voxels
  // Slicing, and the default drawing (texture slabs with termination, which this opacity never reaches).
  for (int slab : {0, Scene{}.slab})
    for (double step : {1.0, 0.5, 0.25}) {
      scene.step = step;
      scene.slab = slab;
      scene.raycast = false;
      const image::ImageF image = renderStore(s, scene);
      // White emission over black: the pixel is the slab's opacity 1 - (1 - alpha)^(L / L_ref), L = 64 voxels.
      const double expected = 1 - std::pow(1 - alpha, 64.0);
      for (int y = 0; y < scene.height; y += 7)
        for (int x = 0; x < scene.width; x += 7)
          ASSERT_NEAR(image.pixel(x, y)[0], expected, 1e-4)
              << "slab " << slab << " step " << step << " pixel " << x << "," << y;
    }
}

TEST(RendererAtlasFormat, NativeAndHalfFormatsStayCloseToFloat) {
  ScratchDir dir;
  // A smooth 8-bit volume (so that filtering precision, not noise, decides the difference).
  const store::Vec3i n{40, 40, 40};
  std::vector<uint8_t> values(size_t(n.volume()));
  for (int64_t z = 0; z < n.z; ++z)
    for (int64_t y = 0; y < n.y; ++y)
      for (int64_t x = 0; x < n.x; ++x) {
        const double r = std::sqrt(double((x - 20) * (x - 20) + (y - 20) * (y - 20) + (z - 20) * (z - 20)));
        values[size_t(x + n.x * (y + n.y * z))] = uint8_t(std::lround(255 * std::exp(-r * r / 200.0)));
      }
  auto s = prepArray(n, store::ValueType::U8, values, dir / "u8", 16);
  const Scene scene = baseScene();
  auto renderWith = [&](AtlasFormat format) {
    auto cache = std::make_shared<store::BrickCache>(s, size_t(64) << 20, 1);
    VolumeRenderer renderer(context(), cache, size_t(64) << 20, format);
    return renderer.render(scene);
  };
  const image::ImageF full = renderWith(AtlasFormat::Float);
  ASSERT_GT(meanBrightness(full), 0.01);
  const image::ImageError native = image::compareImages(renderWith(AtlasFormat::Native), full);
  const image::ImageError half = image::compareImages(renderWith(AtlasFormat::Half), full);
  EXPECT_GT(native.psnr, 35.0) << "native 8-bit atlas: rmse " << native.rmse;
  EXPECT_GT(half.psnr, 45.0) << "half atlas: rmse " << half.rmse;
  std::cout << "8-bit native atlas vs float: " << native.psnr << " dB; half: " << half.psnr << " dB\n";
}

TEST(RendererCli, WritesPngAndStats) {
  ScratchDir dir;
  auto r = test::runVoxbrick("prep synthetic:sparse,n=64 --brick 16 -q -o " + (dir / "s").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  r = test::runVoxbrick("render " + (dir / "s").string() + " -o " + (dir / "f.png").string() +
                        " --size 64x48 --tf sparse" + " --stats " + (dir / "stats.json").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  // It names the renderer it drew with: this context's (llvmpipe here, the GPU's name on a GPU).
  EXPECT_NE(r.output.find(context().renderer()), std::string::npos) << context().renderer() << " in " << r.output;
  const image::Image8 png = image::readPng(dir / "f.png");
  EXPECT_EQ(png.width, 64);
  EXPECT_EQ(png.height, 48);
  const auto stats = test::readFile(dir / "stats.json");
  EXPECT_NE(std::string(stats.begin(), stats.end()).find("\"bricks_skipped_empty\""), std::string::npos);

  r = test::runVoxbrick("render " + (dir / "s").string() + " -o " + (dir / "g.png").string() + " --size 0x10");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("--size: must be WxH, integers between 1 and 8192 pixels"), std::string::npos) << r.output;
  r = test::runVoxbrick("render " + (dir / "s").string() + " -o " + (dir / "g.png").string() + " --tf nosuch");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("nosuch"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace voxbrick::render
