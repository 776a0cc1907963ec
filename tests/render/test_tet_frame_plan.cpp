// The GL-free stages of a mesh frame: the plan (view, window, whether it may ray cast, reference length, the cost
// check), the cost estimate and the visibility order with its empty-tet skipping.
#include <gtest/gtest.h>

#include <array>
#include <memory>
#include <string>

#include "mesh/Topology.h"
#include "render/TetMeshes.h"
#include "render/core/RenderErrors.h"
#include "render/tets/TetFrameCost.h"
#include "render/tets/TetFramePlan.h"
#include "render/tets/TetOrder.h"

namespace voxbrick::render {
namespace {

/// 4^3 cubes of Kuhn tets over [0, 2]^3, value x / 2: scalars in [0, 1].
std::shared_ptr<const TetMeshData> rampMesh() {
  mesh::TetMesh m = test::kuhnGrid(4, 0.0, 2.0, [](const glm::dvec3& p) { return p.x / 2; });
  mesh::Topology t = mesh::buildTopology(m);
  return std::make_shared<const TetMeshData>(std::move(m), std::move(t));
}

Scene smallScene() {
  Scene scene;
  scene.width = 64;
  scene.height = 48;
  return scene;
}

TEST(TetFramePlan, WindowDefaultsToTheScalarRangeAndFollowsTheScene) {
  const auto data = rampMesh();
  Scene scene = smallScene();
  const TetFramePlan plan = planTetFrame(scene, *data, {});
  EXPECT_EQ(plan.view.windowLo, double(data->scalarMin));
  EXPECT_EQ(plan.view.windowHi, double(data->scalarMax));
  EXPECT_DOUBLE_EQ(plan.view.windowLo, 0.0);
  EXPECT_DOUBLE_EQ(plan.view.windowHi, 1.0);
  EXPECT_DOUBLE_EQ(plan.windowScale(), 1.0);
  EXPECT_EQ(plan.width, 64);
  EXPECT_EQ(plan.height, 48);

  scene.window = std::array<double, 2>{0.25, 0.75};
  const TetFramePlan windowed = planTetFrame(scene, *data, {});
  EXPECT_EQ(windowed.view.windowLo, 0.25);
  EXPECT_EQ(windowed.view.windowHi, 0.75);
  EXPECT_DOUBLE_EQ(windowed.windowScale(), 2.0);
}

TEST(TetFramePlan, ReferenceLengthDefaultsToTheMeanEdge) {
  const auto data = rampMesh();
  Scene scene = smallScene();
  EXPECT_EQ(planTetFrame(scene, *data, {}).reference, data->meanEdgeLength);
  scene.transferFunction = TransferFunction({{0.0, {1, 1, 1, 0.1}}, {1.0, {1, 1, 1, 0.1}}}, 0.3);
  EXPECT_EQ(planTetFrame(scene, *data, {}).reference, 0.3);
}

TEST(TetFramePlan, RayCastsOnlyWhenAskedAndTheBoxLiesBeyondTheNearPlane) {
  const auto data = rampMesh();
  Scene scene = smallScene();
  scene.visibility = TetSort::Ray;
  EXPECT_TRUE(planTetFrame(scene, *data, {}).rayCast);  // the fitted orbit sees the whole box

  // The camera inside the box: rays start inside the mesh, where no boundary face is met first.
  Scene inside = scene;
  inside.camera.orbit = false;
  inside.camera.eye = {1, 1, 1};
  inside.camera.center = {1, 1, 0};
  const TetFramePlan insidePlan = planTetFrame(inside, *data, {});
  EXPECT_FALSE(insidePlan.rayCast);
  EXPECT_FALSE(beyondNearPlane(data->bounds, insidePlan.view.camera, insidePlan.view.nearPlane));

  // Outside the box but looking at it: allowed.
  inside.camera.eye = {1, 1, 8};
  EXPECT_TRUE(planTetFrame(inside, *data, {}).rayCast);

  // Not asked for, or the roofline's null fragment program (projected tets only).
  scene.visibility = TetSort::Mpvo;
  EXPECT_FALSE(planTetFrame(scene, *data, {}).rayCast);
  scene.visibility = TetSort::Ray;
  FrameOptions roofline;
  roofline.mode = RenderMode::Roofline;
  const TetFramePlan r = planTetFrame(scene, *data, roofline);
  EXPECT_TRUE(r.nullFragment);
  EXPECT_FALSE(r.rayCast);
}

TEST(TetFramePlan, RefusesPointsModeAndInvalidScenes) {
  const auto data = rampMesh();
  FrameOptions points;
  points.mode = RenderMode::Points;
  EXPECT_THROW(planTetFrame(smallScene(), *data, points), RenderInputError);
  Scene bad = smallScene();
  bad.width = 0;
  EXPECT_THROW(planTetFrame(bad, *data, {}), RenderInputError);
}

TEST(TetFramePlan, RefusesAFrameAboveTheCostLimit) {
  const auto data = rampMesh();
  const size_t tets = data->mesh.tets.size();
  Scene scene = smallScene();
  TetOrder order;
  FrameStats stats;
  order.sort(*data, planTetFrame(scene, *data, {}).view.camera, TetSort::Mpvo, stats);
  ASSERT_EQ(order.size(), tets);

  TetFrameCost cost;
  const TetFramePlan unlimited = planTetFrame(scene, *data, {});
  const double estimate = cost.estimate(*data, unlimited, order.drawn(), order.size());
  // Every tet's vertex stage, and some pixels: the mesh is in view.
  EXPECT_GT(estimate, TetFrameCost::kFragmentsPerTet * double(tets));
  // The ray caster has no vertex stages: the pixels alone.
  EXPECT_DOUBLE_EQ(cost.estimate(*data, unlimited, order.drawn(), 0),
                   estimate - TetFrameCost::kFragmentsPerTet * double(tets));
  EXPECT_NO_THROW(unlimited.checkCost(estimate, tets));

  FrameOptions limited;
  limited.maxSamples = estimate;
  EXPECT_NO_THROW(planTetFrame(scene, *data, limited).checkCost(estimate, tets));
  limited.maxSamples = estimate / 2;
  const TetFramePlan plan = planTetFrame(scene, *data, limited);
  try {
    plan.checkCost(estimate, tets);
    FAIL() << "a frame above the limit was not refused";
  } catch (const RenderLimitError& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(tets) + " tets"), std::string::npos) << e.what();
  }
}

TEST(TetFramePlan, TetsBehindTheEyeCostTheWholeWindow) {
  const auto data = rampMesh();
  Scene scene = smallScene();
  scene.camera.orbit = false;
  scene.camera.eye = {1, 1, 1};
  scene.camera.center = {1, 1, 0};
  const TetFramePlan plan = planTetFrame(scene, *data, {});
  TetOrder order;
  order.none(*data);
  TetFrameCost cost;
  // Tets around the eye reach behind its plane: each of those counts the whole 64 x 48 window.
  EXPECT_GE(cost.estimate(*data, plan, order.drawn(), 0), 64.0 * 48.0);
}

TEST(TetOrder, SkipsTheTetsTheTransferFunctionMakesTransparent) {
  const auto data = rampMesh();
  Scene scene = smallScene();
  // Transparent up to 0.6 of the window: the tets with x below 1 (values up to 0.5) hold nothing.
  scene.transferFunction =
      TransferFunction({{0.0, {1, 1, 1, 0}}, {0.6, {1, 1, 1, 0}}, {0.8, {1, 1, 1, 0.5}}, {1.0, {1, 1, 1, 0.5}}});
  const TetFramePlan plan = planTetFrame(scene, *data, {});
  TetOrder order;
  FrameStats stats;
  order.sort(*data, plan.view.camera, TetSort::Centroid, stats);
  const size_t tets = data->mesh.tets.size();
  ASSERT_EQ(order.size(), tets);
  order.skipEmpty(*data, scene.transferFunction, plan.view, stats);
  EXPECT_EQ(order.size() + size_t(stats.tetsSkippedEmpty), tets);
  // Kuhn cubes of edge 0.5: the two layers of cubes with x in [0, 1] hold values up to 0.5, the other two from 0.5
  // to 1 (each reaching 0.75 or more).
  EXPECT_EQ(size_t(stats.tetsSkippedEmpty), tets / 2);
  for (uint32_t t : order.tets()) {
    EXPECT_TRUE(order.drawn()[t]);
    EXPECT_GT(data->tetRanges[t].second, 0.6f);
  }
  size_t marked = 0;
  for (uint8_t d : order.drawn()) marked += d;
  EXPECT_EQ(marked, order.size());
}

}  // namespace
}  // namespace voxbrick::render
