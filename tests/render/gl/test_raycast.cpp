// The frame ray caster against slicing and slabs: the same samples on the same global planes, found through the
// cell table instead of a proxy per box, must give their image (within 1/255) for any camera, bricking, sub-block,
// budget and level of detail, with either kernel (fragment or compute); the two kernels take the same samples and
// draw the same frames; termination stays within its bound; the cell table's limits fall back to slabs.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "image/Image.h"
#include "render/core/RenderErrors.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/volume/CellTable.h"
#include "render/reference/ReferenceRenderer.h"
#include "render/volume/FramePlan.h"
#include "render/volume/Partition.h"
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

Scene rayCast(Scene scene, RayCaster kernel = RayCaster::Auto) {
  scene.raycast = true;
  scene.raycaster = kernel;
  return scene;
}

/// The tests of the ray caster's frames, run with each kernel.
class RayCastKernel : public testing::TestWithParam<RayCaster> {
 protected:
  Scene rayCast(Scene scene) const { return render::rayCast(std::move(scene), GetParam()); }
  /// Renders with the kernel, and checks that the frame says so.
  image::ImageF render(const std::shared_ptr<const store::BrickStore>& s, const Scene& scene,
                       FrameStats* stats = nullptr, size_t gpuBudget = size_t(256) << 20,
                       const FrameOptions& options = {}) const {
    FrameStats own;
    image::ImageF frame = renderStore(s, scene, &own, gpuBudget, size_t(256) << 20, options);
    EXPECT_EQ(own.raycaster, rayCasterName(GetParam()));
    if (stats) *stats = own;
    return frame;
  }
};

/// The march's cameras, with the axis view from the far side as well.
std::vector<std::pair<std::string, CameraSpec>> cameras() { return test::marchCameras(true); }

TEST_P(RayCastKernel, GivesSlicingsImageForEveryCameraAndCell) {
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
      test::expectSameDrawing(render(s, cast, &stats), sliced, 1.0 / 255, *s, scene,
                              "raycast-sub" + std::to_string(subBlock) + "-" + name);
      // One fragment per pixel whose ray meets the volume, at most.
      EXPECT_LE(stats.fragments, int64_t(scene.width) * scene.height) << name;
      EXPECT_GT(stats.samples, 10 * stats.fragments) << name << ": a whole ray per fragment";
      EXPECT_EQ(stats.slabPasses, 0) << name;
    }
  }
}

TEST_P(RayCastKernel, TakesTheSamplesSlabsTake) {
  ScratchDir dir;
  const auto s = prep("synthetic:sparse,n=96", dir / "s", 16);
  Scene scene = slicing("sparse");
  scene.slab = 8;
  scene.subBlock = 4;
  FrameStats slabbed, cast;
  const image::ImageF slabs = renderStore(s, scene, &slabbed);
  ASSERT_GT(meanBrightness(slabs), 0.001);
  expectClose(render(s, rayCast(scene), &cast), slabs, 1.0 / 255, "raycast-vs-slabs");
  // Every sample a slab takes in a box, the ray caster takes in the box's cells (samples exactly on a face between
  // an empty cell and a drawn one may go either way; they add nothing).
  EXPECT_NEAR(double(cast.samples), double(slabbed.samples), 0.01 * double(slabbed.samples));
  EXPECT_LT(cast.fragments * 4, slabbed.fragments) << "one fragment per pixel, not per box and slab";
  // Sub-blocks skip empty space inside bricks here too: fewer samples than whole bricks would take.
  FrameStats whole;
  scene.subBlock = 0;
  render(s, rayCast(scene), &whole);
  EXPECT_LT(cast.samples * 10, whole.samples * 9);
}

TEST_P(RayCastKernel, ShadingAndPreIntegration) {
  ScratchDir dir;
  const auto s = prep("synthetic:sparse,n=96", dir / "s", 16);
  Scene scene = slicing("sparse");
  scene.shading = true;
  const image::ImageF sliced = renderStore(s, scene);
  ASSERT_GT(meanBrightness(sliced), 0.001);
  for (int subBlock : {0, 4}) {
    Scene cast = rayCast(scene);
    cast.subBlock = subBlock;
    test::expectSameDrawing(render(s, cast), sliced, 1.0 / 255, *s, scene,
                            "raycast-shaded-sub" + std::to_string(subBlock));
  }
  // Pre-integrated: a whole-brick cell is the slab's box, so the back samples are read alike.
  scene.shading = false;
  scene.preIntegration = true;
  scene.slab = 16;
  scene.step = 1;
  const image::ImageF slabs = renderStore(s, scene);
  ASSERT_GT(meanBrightness(slabs), 0.001);
  const image::ImageF cast = render(s, rayCast(scene));
  test::expectSameDrawing(cast, slabs, 1.0 / 255, *s, scene, "raycast-pre-integrated");
  scene.preIntegration = false;
  EXPECT_GT(image::compareImages(render(s, rayCast(scene)), cast).maxAbs, 4.0 / 255)
      << "the table is used: post-classification at this step differs";
}

TEST_P(RayCastKernel, OutOfCoreEqualsInCoreAndTerminationStaysWithinItsBound) {
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
    const image::ImageF reference = render(s, scene, &full);
    ASSERT_GT(meanBrightness(reference), 0.005) << name;
    EXPECT_EQ(full.samplesTerminated, 0) << name;
    FrameStats tight;
    // A budget of a few bricks: many batches, composited one after the other along every ray.
    expectClose(render(s, scene, &tight, size_t(10) * 10 * 10 * 4 * 6, test::batched()),
                reference, 1.0 / 255, "raycast-out-of-core-" + name);
    EXPECT_GT(tight.batches, 5) << name;
    for (double ert : {0.95, 0.999}) {
      scene.ert = ert;
      FrameStats cut;
      // What a terminated ray leaves out is at most its remaining transmittance, 1 - ert, in every channel.
      expectClose(render(s, scene, &cut), reference, (1 - ert) + 1.0 / 255, "raycast-ert-" + name);
      if (name == "oblique") {
        EXPECT_LT(cut.samples * (ert < 0.99 ? 2 : 1), full.samples) << ert;
        EXPECT_GT(cut.samplesTerminated, 0) << ert;
      }
      // Out of core terminated pixels are not marched again in later batches: the silhouette map rejects their
      // fragments, the compute kernel leaves them.
      FrameStats pagedCut;
      expectClose(render(s, scene, &pagedCut, size_t(10) * 10 * 10 * 4 * 6, test::batched()),
                  reference, (1 - ert) + 1.0 / 255, "raycast-ert-out-of-core-" + name);
      if (name == "oblique") {
        EXPECT_LT(pagedCut.fragments, tight.fragments) << ert;
      }
    }
  }
}

TEST_P(RayCastKernel, MixedLevelsGiveSlabsImage) {
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
    expectClose(render(s, rayCast(scene), &cast), slabs, 1.0 / 255, "raycast-lod-sub" + std::to_string(subBlock));
    EXPECT_NEAR(double(cast.samples), double(slabbed.samples), 0.01 * double(slabbed.samples));
    // Out of core, each batch mixing levels.
    const size_t brick = size_t(s->brickEdge()) * s->brickEdge() * s->brickEdge() * 4;
    FrameStats tight;
    expectClose(render(s, rayCast(scene), &tight, 6 * brick, test::batched()), slabs, 1.0 / 255,
                "raycast-lod-out-of-core-sub" + std::to_string(subBlock));
    EXPECT_GT(tight.batches, 3);
  }
}

INSTANTIATE_TEST_SUITE_P(Kernels, RayCastKernel, testing::Values(RayCaster::Fragment, RayCaster::Compute),
                         [](const testing::TestParamInfo<RayCaster>& p) { return rayCasterName(p.param); });

TEST(RayCastKernels, TheComputeKernelDrawsTheFragmentKernelsFrames) {
  // The two kernels march the same code through the same cells and composite with the same formula, the compute
  // kernel in the program where the fragment kernel blends, and the compute kernel skips what the silhouette map
  // rejects: the same frames and the same counts in every case a frame can meet. (A stand-in is a cell of a coarser
  // level, as "levels" draws; which bricks stand in depends on the cache's workers, so no two frames compare.)
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=64", dir / "b", 16);
  const size_t brick = size_t(18 * 18 * 18) * sizeof(float);
  struct Case {
    std::string name;
    Scene scene = test::lodScene(Scene{}.lod);
    FrameOptions options;
    size_t gpuBudget = size_t(256) << 20;
  };
  std::vector<Case> cases;
  auto add = [&](const std::string& name) -> Case& {
    Case& c = cases.emplace_back();
    c.name = name;
    return c;
  };
  add("whole");
  add("no-termination").scene.ert = 0;
  for (const auto& [name, camera] : cameras()) add("camera-" + name).scene.camera = camera;
  {
    Case& c = add("batches");  // an atlas of 6 bricks, levels fixed
    c.scene.lod = 0, c.gpuBudget = 6 * brick, c.options = test::batched();
  }
  {
    Case& c = add("batches-terminated");  // a pixel terminated in one batch is left by the next
    c.scene.lod = 0, c.scene.ert = 0.9, c.gpuBudget = 6 * brick, c.options = test::batched();
    c.scene.transferFunction = TransferFunction::parse(
        R"({"points": [[0, 0, 0, 0, 0], [0.04, 0, 0, 0, 0], [0.08, 1, 0.6, 0.3, 0.9], [1, 1, 1, 1, 1]]})", "opaque");
  }
  add("pre-integration").scene.preIntegration = true;
  add("shading").scene.shading = true;
  add("levels").scene.lod = 4;
  add("part").options.part = partitionBricks(*s, 3).boxes[1];  // premultiplied, no background
  add("transparent").scene.transparent = true;
  add("roofline").options.mode = RenderMode::Roofline;
  {
    Case& c = add("tiles");  // checkpoints every few workgroups: tiles of part of a row
    c.options.cancelled = [] { return false; };
    c.options.checkpointSamples = 5000;
  }
  for (Case& c : cases) {
    FrameStats fragment, compute;
    const image::ImageF f = renderStore(s, rayCast(c.scene, RayCaster::Fragment), &fragment, c.gpuBudget,
                                        size_t(256) << 20, c.options);
    const image::ImageF g = renderStore(s, rayCast(c.scene, RayCaster::Compute), &compute, c.gpuBudget,
                                        size_t(256) << 20, c.options);
    EXPECT_EQ(fragment.raycaster, "fragment") << c.name;
    EXPECT_EQ(compute.raycaster, "compute") << c.name;
    if (c.options.mode != RenderMode::Roofline) {
      EXPECT_GT(meanBrightness(f), 0.005) << c.name;
    }
    test::expectSameDrawing(g, f, 1.0 / 255, *s, c.scene, "compute-vs-fragment-" + c.name);
    const image::ImageError e = image::compareImages(g, f);
    std::printf("[ info ] %s: compute vs fragment max |diff| %.3g\n", c.name.c_str(), e.maxAbs);
    EXPECT_EQ(compute.samples, fragment.samples) << c.name;
    EXPECT_EQ(compute.fragments, fragment.fragments) << c.name << ": one invocation per pixel the fragment kernel starts";
    EXPECT_EQ(compute.samplesTerminated, fragment.samplesTerminated) << c.name;
    EXPECT_EQ(compute.batches, fragment.batches) << c.name;
    if (c.name == "batches" || c.name == "batches-terminated") {
      EXPECT_GT(compute.batches, 2) << c.name;
    }
    if (c.name == "batches-terminated") {
      EXPECT_GT(compute.samplesTerminated, 0);
    }
    if (c.name == "levels") {
      EXPECT_GT(compute.bricksCoarse, 0);
    }
  }
}

TEST(RayCastKernels, AutoChoosesByDevice) {
  // auto: the compute kernel on NVIDIA, the fragment kernel on a software rasteriser (where the compute kernel was
  // never clearly the faster) and elsewhere; the scene may still ask for either.
  const GlContext& context = test::context();
  const bool nvidia = !context.software() && context.renderer().find("NVIDIA") != std::string::npos;
  const char* autoKernel = nvidia ? "compute" : "fragment";
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=48", dir / "b", 16);
  for (const auto& [kernel, want] : {std::pair{RayCaster::Auto, autoKernel}, std::pair{RayCaster::Fragment, "fragment"},
                                     std::pair{RayCaster::Compute, "compute"}}) {
    FrameStats stats;
    renderStore(s, rayCast(test::lodScene(1), kernel), &stats);
    EXPECT_EQ(stats.raycaster, want) << rayCasterName(kernel);
    EXPECT_EQ(stats.toJson().value("raycaster", ""), want);
  }
  FrameStats sliced;
  renderStore(s, slicing("hot"), &sliced);
  EXPECT_TRUE(sliced.raycaster.empty()) << "a frame not ray cast names no kernel";
  EXPECT_FALSE(sliced.toJson().contains("raycaster"));
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
  // The kernel: by name, auto by default, kept by toJson; another name is refused.
  EXPECT_EQ(Scene().raycaster, RayCaster::Auto);
  EXPECT_EQ(Scene::fromJson(R"({"raycaster": "compute"})", "t").raycaster, RayCaster::Compute);
  EXPECT_EQ(Scene::fromJson(R"({"raycaster": "fragment"})", "t").raycaster, RayCaster::Fragment);
  def.raycaster = RayCaster::Compute;
  EXPECT_EQ(Scene::fromJson(def.toJson(), "t").raycaster, RayCaster::Compute);
  EXPECT_THROW(Scene::fromJson(R"({"raycaster": "vertex"})", "t"), RenderInputError);
  EXPECT_THROW(Scene::fromJson(R"({"raycaster": true})", "t"), RenderInputError);
}

}  // namespace
}  // namespace voxbrick::render
