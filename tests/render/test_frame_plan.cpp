// The frame plan, without GL: value window, step and reference length, the transfer table's texel widening of the
// skip test, draw-box margins, sub-block sizes, the traversal it carries and the pixel rays of exact ownership.
#include <gtest/gtest.h>

#include <cmath>
#include <tuple>

#include "render/RenderFixtures.h"
#include "render/core/RenderErrors.h"
#include "render/volume/FramePlan.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

constexpr int kTexels = 4096;

/// 40 x 24 x 16 float voxels, value = x, spacing (1, 2, 0.5): anisotropic, and not a multiple of the brick size.
std::shared_ptr<const store::BrickStore> rampStore(const test::ScratchDir& dir, int brick = 16) {
  const store::Vec3i n{40, 24, 16};
  std::vector<float> values(size_t(n.x * n.y * n.z));
  for (size_t i = 0; i < values.size(); ++i) values[i] = float(i % size_t(n.x));
  return test::prepArray(n, store::ValueType::F32, values, dir / "ramp.vbs", brick, {1, 2, 0.5});
}

TEST(FramePlan, WindowStepAndReferenceLengthFollowTheSceneAndStore) {
  test::ScratchDir dir;
  const auto s = rampStore(dir);
  Scene scene;
  scene.step = 0.8;
  FramePlan plan = planFrame(scene, *s, kTexels);
  EXPECT_DOUBLE_EQ(plan.window.lo, 0.0);
  EXPECT_DOUBLE_EQ(plan.window.hi, 39.0);
  EXPECT_DOUBLE_EQ(plan.window.inverseWidth, 1.0 / 39.0);
  EXPECT_DOUBLE_EQ(plan.step, 0.8 * 0.5) << "steps are in voxels of the smallest spacing";
  EXPECT_DOUBLE_EQ(plan.referenceLength, 0.5) << "default reference length: the smallest spacing";

  scene.window = std::array<double, 2>{10, 20};
  scene.transferFunction = TransferFunction({{0.0, {1, 1, 1, 0.1}}, {1.0, {1, 1, 1, 0.1}}}, 3.0);
  plan = planFrame(scene, *s, kTexels);
  EXPECT_DOUBLE_EQ(plan.window.lo, 10.0);
  EXPECT_DOUBLE_EQ(plan.window.hi, 20.0);
  EXPECT_DOUBLE_EQ(plan.referenceLength, 3.0);
  EXPECT_NEAR(glm::length(plan.planeNormal), 1.0, 1e-12);
  EXPECT_NEAR(glm::dot(plan.planeNormal, plan.camera.viewDirection()), 1.0, 1e-12);
}

TEST(FramePlan, AConstantVolumeGetsAUnitWindow) {
  test::ScratchDir dir;
  const auto s =
      test::prepArray(store::Vec3i{8, 8, 8}, store::ValueType::F32, std::vector<float>(512, 5.0f), dir / "flat.vbs", 8);
  const FramePlan plan = planFrame(Scene{}, *s, kTexels);
  EXPECT_DOUBLE_EQ(plan.window.lo, 5.0);
  EXPECT_DOUBLE_EQ(plan.window.hi, 6.0);
}

TEST(FramePlan, TheSkipTestIsWidenedByOneTableTexel) {
  test::ScratchDir dir;
  const auto s = rampStore(dir);
  Scene scene;
  // Opaque only above 0.5 of the window [0, 39].
  scene.transferFunction =
      TransferFunction({{0.0, {1, 1, 1, 0}}, {0.5, {1, 1, 1, 0}}, {0.5, {1, 1, 1, 1}}, {1.0, {1, 1, 1, 1}}});
  const FramePlan plan = planFrame(scene, *s, kTexels);
  const float edge = float(0.5 * 39);
  const float halfTexel = float(0.5 * 39.0 / kTexels), fourTexels = float(4 * 39.0 / kTexels);
  EXPECT_TRUE(plan.contributes(edge, edge + 1));
  EXPECT_TRUE(plan.contributes(edge - 5, edge - halfTexel)) << "within one texel of the opaque region";
  EXPECT_FALSE(plan.contributes(edge - 5, edge - fourTexels)) << "a few texels away the GPU sees no opacity";
  EXPECT_FALSE(plan.contributes(0, 1));
}

TEST(FramePlan, CarriesTheTraversalOfItsCamera) {
  test::ScratchDir dir;
  const auto s = rampStore(dir);
  Scene scene;
  const FramePlan plan = planFrame(scene, *s, kTexels);
  const OctreeTraversal traversal(s->octree(), s->meta().dims, s->brickSize(), s->meta().spacing);
  const TraversalResult expected =
      traversal.run(plan.camera, Frustum::fromMatrix(plan.viewProj), plan.contributes, {true, true, {}, {}});
  ASSERT_EQ(plan.visible.bricks.size(), expected.bricks.size());
  for (size_t i = 0; i < expected.bricks.size(); ++i) EXPECT_EQ(plan.visible.bricks[i].key, expected.bricks[i].key);
  EXPECT_EQ(plan.visible.stats.bricksDrawn, 3 * 2 * 1) << "every brick of a 40x24x16 ramp at B=16 is drawn";
}

TEST(FramePlan, DrawBoxesGrowAtTheSurfaceAndBetweenSubBlocksOnly) {
  test::ScratchDir dir;
  const auto s = rampStore(dir);
  const store::Vec3d& spacing = s->meta().spacing;
  Scene scene;
  scene.slab = 0;  // slicing whole bricks: they share their rasterised faces
  scene.raycast = false;
  scene.subBlock = 0;
  FramePlan plan = planFrame(scene, *s, kTexels);
  ASSERT_EQ(plan.subBlock, 0);
  // Brick (0, 0, 0) of B = 16: its low faces are on the surface, its high x and y faces are interior, its high z
  // face (16 = nz) is on the surface too.
  const Box brick = voxelSpanBox({0, 0, 0}, {16, 16, 16}, s->meta().dims, spacing);
  Box drawn = plan.drawBox(brick, spacing);
  for (int a = 0; a < 3; ++a)
    EXPECT_DOUBLE_EQ(drawn.min[a], brick.min[a] - FramePlan::kSurfaceMargin * spacing[a]) << "axis " << a;
  EXPECT_DOUBLE_EQ(drawn.max.x, brick.max.x);
  EXPECT_DOUBLE_EQ(drawn.max.y, brick.max.y);
  EXPECT_DOUBLE_EQ(drawn.max.z, brick.max.z + FramePlan::kSurfaceMargin * spacing.z);

  scene.subBlock = 4;
  plan = planFrame(scene, *s, kTexels);
  ASSERT_EQ(plan.subBlock, 4);
  drawn = plan.drawBox(brick, spacing);
  EXPECT_DOUBLE_EQ(drawn.max.x, brick.max.x + FramePlan::kInteriorMargin * spacing.x);
  EXPECT_DOUBLE_EQ(drawn.max.y, brick.max.y + FramePlan::kInteriorMargin * spacing.y);

  scene.subBlock = 16;  // not below the brick size: whole bricks
  EXPECT_EQ(planFrame(scene, *s, kTexels).subBlock, 0);

  scene.slab = 16;  // slabs own their voxels exactly, as sub-blocks do
  scene.raycast = false;
  plan = planFrame(scene, *s, kTexels);
  ASSERT_TRUE(plan.exactOwnership());
  EXPECT_DOUBLE_EQ(plan.drawBox(brick, spacing).max.x, brick.max.x + FramePlan::kInteriorMargin * spacing.x);
}

TEST(FramePlan, PixelRaysPassThroughTheirPixels) {
  test::ScratchDir dir;
  const auto s = rampStore(dir);
  for (bool ortho : {false, true}) {
    Scene scene;
    scene.width = 64;
    scene.height = 40;
    scene.camera.orthographic = ortho;
    const FramePlan plan = planFrame(scene, *s, kTexels);
    for (const glm::dvec2 pixel : {glm::dvec2(0.5, 0.5), glm::dvec2(31.5, 17.5), glm::dvec2(63.5, 39.5)}) {
      const PixelRays& r = plan.rays;
      const glm::dvec3 origin = r.origin + pixel.x * r.originDx + pixel.y * r.originDy;
      const glm::dvec3 direction = r.direction + pixel.x * r.directionDx + pixel.y * r.directionDy;
      for (double t : {0.0, 0.3, 1.0}) {
        const glm::dvec4 clip = plan.viewProj * glm::dvec4(origin + t * direction, 1.0);
        EXPECT_NEAR((clip.x / clip.w + 1) * 0.5 * scene.width, pixel.x, 1e-6) << "ortho " << ortho << ", t " << t;
        EXPECT_NEAR((clip.y / clip.w + 1) * 0.5 * scene.height, pixel.y, 1e-6) << "ortho " << ortho << ", t " << t;
      }
    }
  }
}

TEST(FramePlan, AnInvalidSceneIsRefused) {
  test::ScratchDir dir;
  const auto s = rampStore(dir);
  Scene scene;
  scene.step = 0;
  EXPECT_THROW(planFrame(scene, *s, kTexels), RenderInputError);
}

TEST(FramePlan, SegmentRatiosSpanThePixelRays) {
  test::ScratchDir dir;
  const auto s = rampStore(dir);
  Scene scene;
  scene.step = 0.8;
  scene.width = 64;
  scene.height = 48;
  scene.camera.fovY = 60;
  FramePlan plan = planFrame(scene, *s, kTexels);
  const double ratio = plan.step / plan.referenceLength;
  auto [lo, hi] = plan.segmentRatios();
  // The centre ray runs along the view axis (cosine 1); the corner rays are the most oblique: with a 60° vertical
  // field of view and a 4:3 image, tan of the corner's angle is tan(30°) * sqrt(1 + (4/3)^2), less half a pixel.
  EXPECT_NEAR(lo, ratio, 1e-3 * ratio);
  const double cornerTan = std::tan(glm::radians(30.0)) * std::hypot(1.0, 4.0 / 3.0);
  EXPECT_NEAR(hi, ratio * std::sqrt(1 + cornerTan * cornerTan), 0.02 * ratio);
  EXPECT_GT(hi, lo * 1.3);
  scene.camera.orthographic = true;
  plan = planFrame(scene, *s, kTexels);
  std::tie(lo, hi) = plan.segmentRatios();
  EXPECT_EQ(lo, ratio);
  EXPECT_EQ(hi, ratio);
}

}  // namespace
}  // namespace voxbrick::render
