// Ray-driven residency (render/gl/volume/RayRequests.h): the bricks a ray-cast frame pages are those its rays reach and
// do not find resident, recorded by both kernels; meanwhile a stand-in is drawn; after a few frames of a still camera
// the image is the octree mode's, sample for sample, and a brick behind an opaque front was never paged.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "image/Image.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/volume/VolumeRenderer.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::prep;
using test::ScratchDir;

/// Two concentric shells (128³ voxels in bricks of 16: 8³ bricks), opaque where a shell peaks, so that the outer
/// shell hides the inner one from every eye outside it; early ray termination on.
Scene shellsScene(RayCaster kernel, ResidencyMode mode) {
  Scene scene = test::slicingScene("hot");
  scene.raycast = true;
  scene.raycaster = kernel;
  scene.subBlock = 4;
  scene.lod = 0;
  scene.ert = 0.99;
  scene.width = scene.height = 40;
  scene.transferFunction = TransferFunction(
      {{0.0, {0, 0, 0, 0}}, {0.2, {0.9, 0.3, 0.1, 0.0}}, {0.6, {1.0, 0.7, 0.3, 1.0}}, {1.0, {1.0, 1.0, 1.0, 1.0}}});
  scene.residency = mode;
  return scene;
}

// A brick holding only the inner shell: its voxels [48, 64)³ lie within 28 voxels of the centre, the outer shell's
// within 32 to 53.
const store::BrickKey kHidden{0, 3, 3, 3};

struct ResidencyRenderer {
  explicit ResidencyRenderer(std::shared_ptr<const store::BrickStore> s)
      : cache(std::make_shared<store::BrickCache>(std::move(s), size_t(256) << 20, 1)),
        renderer(test::context(), cache, size_t(256) << 20) {}
  std::shared_ptr<store::BrickCache> cache;
  VolumeRenderer renderer;
};

class RayResidency : public ::testing::TestWithParam<RayCaster> {};

TEST_P(RayResidency, ConvergesToTheOctreeImageAndNeverPagesTheHiddenBrick) {
  ScratchDir dir;
  const auto store = prep("synthetic:shells,n=128,count=2", dir / "s", 16);
  ResidencyRenderer rays(store);
  const Scene scene = shellsScene(GetParam(), ResidencyMode::Rays);

  FrameStats stats;
  const image::ImageF cold = rays.renderer.render(scene, &stats);
  EXPECT_EQ(stats.raycaster, GetParam() == RayCaster::Compute ? "compute" : "fragment");
  EXPECT_TRUE(stats.fallback.empty()) << stats.fallback;
  EXPECT_GT(stats.bricksRequested, 0) << "the rays of a cold frame request the bricks they reach";
  EXPECT_GT(stats.bricksStandIn, 0) << "a cold frame draws stand-ins";
  EXPECT_LT(stats.bricksPagedIn, stats.bricksDrawn) << "a cold frame pages stand-ins' sources, not every brick";
  EXPECT_GT(test::meanBrightness(cold), 0.002) << "the stand-ins are drawn";
  int64_t paged = stats.bricksPagedIn;
  int frames = 1;
  constexpr int kMaxFrames = 6;
  while (stats.bricksRequested > 0 && frames < kMaxFrames) {
    rays.renderer.render(scene, &stats);
    paged += stats.bricksPagedIn;
    ++frames;
  }
  ASSERT_EQ(stats.bricksRequested, 0) << "no convergence within " << kMaxFrames << " frames";
  EXPECT_GT(stats.bricksUntouched, 0) << "bricks behind the outer shell are reached by no ray";
  const image::ImageF converged = rays.renderer.render(scene, &stats);
  EXPECT_EQ(stats.bricksPagedIn, 0);
  EXPECT_EQ(stats.cellBricksChanged, 0) << "a converged frame draws what the last one drew";
  EXPECT_FALSE(rays.renderer.atlas().slots().resident(kHidden)) << "the hidden brick was paged";

  // The octree mode pages every visible brick, the hidden one too, and draws the same image: on this renderer (the
  // same slots for the bricks the rays paged) bit for bit.
  Scene octree = scene;
  octree.residency = ResidencyMode::Octree;
  FrameStats octreeStats;
  const image::ImageF exact = rays.renderer.render(octree, &octreeStats);
  EXPECT_GT(octreeStats.bricksPagedIn, 0) << "the octree pages what no ray reached";
  EXPECT_TRUE(rays.renderer.atlas().slots().resident(kHidden));
  EXPECT_EQ(octreeStats.bricksRequested, 0);
  EXPECT_EQ(octreeStats.bricksUntouched, 0);
  EXPECT_EQ(image::compareImages(converged, exact).maxAbs, 0.0) << "the converged image is not the octree mode's";

  // A renderer of the octree mode alone pages more than the rays did in all their frames; its slots differ, so its
  // image may differ by the atlas coordinates' round-off only.
  ResidencyRenderer alone(store);
  FrameStats aloneStats;
  const image::ImageF fresh = alone.renderer.render(octree, &aloneStats);
  EXPECT_LT(paged, aloneStats.bricksPagedIn) << "the rays paged no fewer bricks than the octree";
  EXPECT_LE(image::compareImages(converged, fresh).maxAbs, 1.0 / 255);
}

TEST_P(RayResidency, StatsKeysExistAndMove) {
  ScratchDir dir;
  ResidencyRenderer rays(prep("synthetic:shells,n=128,count=2", dir / "s", 16));
  const Scene scene = shellsScene(GetParam(), ResidencyMode::Rays);
  FrameStats first, second;
  rays.renderer.render(scene, &first);
  rays.renderer.render(scene, &second);
  const nlohmann::json a = first.toJson(), b = second.toJson();
  ASSERT_TRUE(a.contains("bricks_requested"));
  ASSERT_TRUE(a.contains("bricks_untouched"));
  EXPECT_GT(a["bricks_requested"].get<int64_t>(), 0);
  EXPECT_GT(b["bricks_paged_in"].get<int64_t>(), 0) << "the second frame pages what the first requested";
  EXPECT_NE(a["bricks_requested"], b["bricks_requested"]);
  EXPECT_GT(b["bricks_untouched"].get<int64_t>(), 0);
  // The octree mode requests nothing and leaves nothing untouched.
  Scene octree = scene;
  octree.residency = ResidencyMode::Octree;
  FrameStats third;
  rays.renderer.render(octree, &third);
  const nlohmann::json c = third.toJson();
  EXPECT_EQ(c["bricks_requested"].get<int64_t>(), 0);
  EXPECT_EQ(c["bricks_untouched"].get<int64_t>(), 0);
  EXPECT_GT(c["bricks_paged_in"].get<int64_t>(), 0) << "the octree pages the bricks no ray reached";
}

INSTANTIATE_TEST_SUITE_P(Kernels, RayResidency, ::testing::Values(RayCaster::Fragment, RayCaster::Compute),
                         [](const auto& p) { return std::string(rayCasterName(p.param)); });

}  // namespace
}  // namespace voxbrick::render
