// The tet mesh renderer (seed 002): frames against analytic opacities, MPVO against the centroid order, and the
// visibility orders themselves.
#include <gtest/gtest.h>

#include <cmath>

#include "mesh/MeshStoreFixtures.h"
#include "mesh/Visibility.h"
#include "render/RenderErrors.h"
#include "render/RenderFixtures.h"
#include "render/TetRenderer.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

std::shared_ptr<const TetMeshData> gridData(int n, float scalar = -1) {
  mesh::TetMesh m = mesh::test::kuhnGrid(n, n, n);
  if (scalar >= 0)
    for (float& s : m.scalars) s = scalar;
  mesh::Topology t = mesh::test::matchFaces(m);
  return std::make_shared<const TetMeshData>(std::move(m), std::move(t));
}

TEST(TetRenderer, ConstantScalarGivesTheAnalyticOpacity) {
  // A cube of n^3 unit cells seen along -z, orthographic: every ray through its face crosses n units.
  const int n = 6;
  auto data = gridData(n, 0.5f);
  Scene scene;
  scene.width = scene.height = 64;
  scene.camera.eye = glm::dvec3(3, 3, 40);
  scene.camera.center = glm::dvec3(3, 3, 3);
  scene.camera.orthographic = true;
  scene.camera.orbit = false;
  scene.camera.fovY = 30;
  const double alpha = 0.05;
  scene.transferFunction = TransferFunction({{0, {1, 1, 1, alpha}}, {1, {1, 1, 1, alpha}}}, 1.0);
  scene.window = std::array<double, 2>{0, 1};
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  FrameStats stats;
  const image::ImageF image = renderer.render(scene, &stats);
  EXPECT_EQ(stats.tetsDrawn, int64_t(6 * n * n * n));
  const double want = 1 - std::pow(1 - alpha, double(n));
  // The centre pixel (the cube's centre is in the middle of the view): white over black, opacity `want`.
  const float* centre = image.pixel(32, 32);
  EXPECT_NEAR(centre[0], want, 2e-3);
  // A corner pixel is outside the cube's projection (the view is 2 * 37 * tan 15 = 19.8 units tall).
  EXPECT_NEAR(image.pixel(1, 1)[0], 0.0, 1e-6);
}

TEST(TetRenderer, MpvoAndCentroidOrdersAgreeOnAConvexGrid) {
  auto data = gridData(8);
  Scene scene = test::lodScene(0);
  scene.camera.distance = 2.5;
  scene.transferFunction = TransferFunction::load("hot");
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  scene.visibility = TetSort::Mpvo;
  const image::ImageF mpvo = renderer.render(scene);
  ASSERT_GT(test::meanBrightness(mpvo), 0.01);
  scene.visibility = TetSort::Centroid;
  const image::ImageF centroid = renderer.render(scene);
  // Centroid order misplaces tets of a Kuhn grid against their neighbours only where their centroids tie in depth
  // for the view; MPVO is exact. The frames agree closely on such a regular grid.
  test::expectClose(mpvo, centroid, 2.0 / 255, "tets-mpvo-vs-centroid");
}

}  // namespace
}  // namespace voxbrick::render

namespace voxbrick::render {
namespace {
TEST(TetRendererProbe, DISABLED_Timing) {
  auto data = gridData(55);
  Scene scene = test::lodScene(0);
  scene.width = scene.height = 512;
  scene.transferFunction = TransferFunction::load("hot");
  TetRenderer renderer(test::context(), data, size_t(1) << 30);
  for (TetSort sort : {TetSort::Mpvo, TetSort::Centroid})
    for (int i = 0; i < 3; ++i) {
      scene.visibility = sort;
      FrameStats stats;
      renderer.render(scene, &stats);
      std::printf("%s tets %lld sort %.1f ms draw %.1f ms total %.1f ms fragments %lld\n", tetSortName(sort),
                  (long long)stats.tetsDrawn, stats.msSorting, stats.msDrawing, stats.msTotal,
                  (long long)stats.fragments);
    }
  FrameStats stats;
  renderer.render(scene, &stats, {RenderMode::Roofline});
  std::printf("null fragment: draw %.1f total %.1f\n", stats.msDrawing, stats.msTotal);
}
}  // namespace
}  // namespace voxbrick::render
