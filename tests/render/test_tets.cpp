// The tet mesh renderer (seed 002): frames against analytic opacities, MPVO against the centroid order, and the
// visibility orders themselves.
#include <gtest/gtest.h>

#include <cmath>

#include <nlohmann/json.hpp>

#include "image/Image.h"
#include "mesh/MeshStoreFixtures.h"
#include "mesh/MeshWriters.h"
#include "mesh/SyntheticMesh.h"
#include "mesh/Topology.h"
#include "mesh/Visibility.h"
#include "render/RenderErrors.h"
#include "render/RenderFixtures.h"
#include "render/TetReference.h"
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

// The GPU frame against the exact reference (closed-form integration through every tet the pixel's ray meets): on
// the staircase ball (a non-convex boundary), perspective from outside, close up and orthographic, for two transfer
// functions. The bound: the pre-integrated table's lookup (render/PreIntegration.h: at most 6e-3 in a segment's
// opacity near a transfer function's kinks, 2e-4 on average) and float arithmetic; measured 1/255 at most.
TEST(TetRenderer, FramesMatchTheExactReference) {
  auto m = mesh::syntheticMesh("ball,n=12");
  mesh::Topology t = mesh::buildTopology(m);
  auto data = std::make_shared<const TetMeshData>(std::move(m), std::move(t));
  const TetReference reference(data->mesh);
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  struct View {
    std::string name;
    CameraSpec camera;
  };
  std::vector<View> views(3);
  views[0] = {"orbit", {}};
  views[0].camera.azimuth = 35;
  views[0].camera.elevation = 25;
  views[1] = {"close", {}};
  views[1].camera.distance = 1.3;
  views[2] = {"orthographic", {}};
  views[2].camera.orthographic = true;
  views[2].camera.azimuth = 90;
  views[2].camera.elevation = 0;
  for (const std::string tf : {"hot", "ct-bone"})
    for (const View& v : views) {
      Scene scene;
      scene.width = 96;
      scene.height = 80;
      scene.camera = v.camera;
      scene.transferFunction = TransferFunction::load(tf);
      FrameStats stats;
      const image::ImageF gpu = renderer.render(scene, &stats);
      TetReferenceStats refStats;
      const image::ImageF exact =
          reference.render(TetReferenceParams::fromScene(scene, data->mesh, data->meanEdgeLength), &refStats);
      ASSERT_GT(test::meanBrightness(exact), 0.005) << tf << " " << v.name;
      test::expectClose(gpu, exact, 2.0 / 255, "tets-reference-" + tf + "-" + v.name);
      // A fragment per segment of positive length the reference found, up to the pixels on shared edges.
      EXPECT_NEAR(double(stats.fragments), double(refStats.segments), 0.01 * double(refStats.segments)) << v.name;
    }
}

// A mesh file end to end through the command: prep (a binary VTK file, then the same file again without and with
// --force), info, render; a file of hexahedra is refused naming them, and nothing is written.
TEST(TetCommands, PrepInfoRenderAndRefusals) {
  test::ScratchDir dir;
  mesh::TetMesh ball = mesh::syntheticMesh("ball,n=8");
  mesh::writeVtk(ball, dir / "ball.vtk", true);
  auto r = test::runVoxbrick("prep " + (dir / "ball.vtk").string() + " -q -o " + (dir / "ball").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("prep: wrote mesh store"), std::string::npos) << r.output;
  r = test::runVoxbrick("info --json " + (dir / "ball").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const nlohmann::json info = nlohmann::json::parse(r.output);
  EXPECT_EQ(info["kind"], "tet-mesh");
  EXPECT_EQ(info["tets"].get<size_t>(), ball.tets.size());
  EXPECT_EQ(info["field"], ball.field);
  r = test::runVoxbrick("prep " + (dir / "ball.vtk").string() + " -q -o " + (dir / "ball").string());
  EXPECT_NE(r.exitCode, 0) << "an existing store is replaced only with --force";
  r = test::runVoxbrick("prep " + (dir / "ball.vtk").string() + " -q --force -o " + (dir / "ball").string());
  EXPECT_EQ(r.exitCode, 0) << r.output;
  r = test::runVoxbrick("render " + (dir / "ball").string() + " --size 64x48 --tf hot -q -o " +
                        (dir / "ball.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("tets drawn in mpvo order"), std::string::npos) << r.output;
  const image::Image8 png = image::readPng(dir / "ball.png");
  EXPECT_EQ(png.width, 64);
  size_t lit = 0;
  for (size_t i = 0; i < png.rgba.size(); i += 4) lit += png.rgba[i] > 10 ? 1 : 0;
  EXPECT_GT(lit, 200u);

  test::writeFile(dir / "hex.vtk",
                  std::string("# vtk DataFile Version 3.0\nhex\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 8 float\n"
                              "0 0 0 1 0 0 0 1 0 1 1 0 0 0 1 1 0 1 0 1 1 1 1 1\nCELLS 1 9\n8 0 1 3 2 4 5 7 6\n"
                              "CELL_TYPES 1\n12\nPOINT_DATA 8\nSCALARS s float\nLOOKUP_TABLE default\n"
                              "0 1 2 3 4 5 6 7\n"));
  r = test::runVoxbrick("prep " + (dir / "hex.vtk").string() + " -q -o " + (dir / "hex").string());
  EXPECT_NE(r.exitCode, 0);
  EXPECT_NE(r.output.find("hexahedron"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "hex"));
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
