// Texture slabs against slicing: the same samples on the same global planes, composited in registers per slab and
// blended once, must give slicing's image (within 1/255) for any slab size, camera, bricking and budget.
#include <gtest/gtest.h>

#include <string>

#include "render/RenderErrors.h"
#include "render/RenderFixtures.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::expectClose;
using test::meanBrightness;
using test::prep;
using test::renderStore;
using test::ScratchDir;

Scene sceneFor(const std::string& tf) {
  Scene scene;
  scene.width = 96;
  scene.height = 80;
  scene.camera.azimuth = 35;
  scene.camera.elevation = 25;
  scene.camera.distance = 2.2;
  scene.transferFunction = TransferFunction::load(tf);
  scene.step = 0.5;
  return scene;
}

/// Cameras that stress the ray marcher: oblique perspective, a view along an axis (planes through brick faces),
/// orthographic, and an eye inside the volume (the near plane cuts bricks).
std::vector<std::pair<std::string, CameraSpec>> cameras() {
  std::vector<std::pair<std::string, CameraSpec>> out;
  CameraSpec c;
  c.azimuth = 35, c.elevation = 25, c.distance = 2.2;
  out.push_back({"oblique", c});
  CameraSpec axis;
  axis.orbit = false;
  axis.eye = {0, 0, 300};
  out.push_back({"axis", axis});
  CameraSpec ortho = c;
  ortho.orthographic = true;
  ortho.azimuth = 200, ortho.elevation = -40;
  out.push_back({"ortho", ortho});
  CameraSpec inside = c;
  inside.distance = 0.25, inside.fovY = 75;
  out.push_back({"inside", inside});
  return out;
}

TEST(Slabs, EverySlabSizeGivesSlicingsImage) {
  ScratchDir dir;
  const auto s = prep("synthetic:marschner-lobb,n=40", dir / "ml", 16);
  for (const auto& [name, camera] : cameras()) {
    Scene scene = sceneFor("hot");
    scene.camera = camera;
    const image::ImageF sliced = renderStore(s, scene);
    ASSERT_GT(meanBrightness(sliced), 0.005) << name;
    for (int slab : {1, 3, 16, Scene::kMaxSlab}) {
      scene.slab = slab;
      expectClose(renderStore(s, scene), sliced, 1.0 / 255, "slab-" + std::to_string(slab) + "-" + name);
    }
  }
}

TEST(Slabs, ShadingSubBlocksAndSparseData) {
  ScratchDir dir;
  const auto s = prep("synthetic:sparse,n=96", dir / "s", 16);
  Scene scene = sceneFor("sparse");
  scene.shading = true;
  const image::ImageF sliced = renderStore(s, scene);
  ASSERT_GT(meanBrightness(sliced), 0.001);
  for (int subBlock : {0, 4}) {
    scene.subBlock = subBlock;
    scene.slab = 8;
    expectClose(renderStore(s, scene), sliced, 1.0 / 255, "slab-8-shaded-sub" + std::to_string(subBlock));
  }
}

TEST(Slabs, OutOfCoreEqualsInCoreAndFewerFragmentsForLargerSlabs) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=48", dir / "b", 8);
  Scene scene = sceneFor("hot");
  FrameStats one, four, whole, tight;
  scene.slab = 1;
  const image::ImageF roomy = renderStore(s, scene, &one);
  scene.slab = 4;
  const image::ImageF byFour = renderStore(s, scene, &four);
  scene.slab = Scene::kMaxSlab;
  const image::ImageF wholeBricks = renderStore(s, scene, &whole);
  // A budget of a few bricks: many batches, bricks evicted and paged again.
  const image::ImageF paged = renderStore(s, scene, &tight, size_t(10) * 10 * 10 * 4 * 6);
  EXPECT_GT(tight.batches, 5);
  expectClose(paged, wholeBricks, 1.0 / 255, "slab-out-of-core");
  expectClose(byFour, roomy, 1.0 / 255, "slab-4-vs-1");
  expectClose(wholeBricks, roomy, 1.0 / 255, "slab-whole-vs-1");
  // A fragment carries up to N samples: fewer fragments as slabs grow.
  EXPECT_LT(four.fragments * 2, one.fragments);
  EXPECT_LT(whole.fragments, four.fragments);
  EXPECT_EQ(whole.bricksDrawn, one.bricksDrawn);
}

TEST(Slabs, TheSceneKeyIsChecked) {
  EXPECT_EQ(Scene::fromJson(R"({"slab": 16})", "t").slab, 16);
  EXPECT_EQ(Scene::fromJson("{}", "t").slab, 0) << "slicing is the default";
  for (const char* bad : {R"({"slab": -1})", R"({"slab": 2.5})", R"({"slab": 5000})", R"({"slab": "4"})"})
    EXPECT_THROW(Scene::fromJson(bad, "t"), RenderInputError) << bad;
  Scene scene;
  scene.slab = 7;
  EXPECT_EQ(Scene::fromJson(scene.toJson(), "t").slab, 7) << "toJson keeps it";
}

}  // namespace
}  // namespace voxbrick::render
