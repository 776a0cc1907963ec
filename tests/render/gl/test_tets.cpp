// The tet mesh renderer (Carrard & Juliachs): frames against analytic opacities, MPVO against the centroid order,
// and the visibility orders themselves; sort-last parts (FrameOptions::meshPart) joined into the whole frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include <nlohmann/json.hpp>

#include "image/Image.h"
#include "mesh/MeshStoreFixtures.h"
#include "mesh/MeshWriters.h"
#include "mesh/SyntheticMesh.h"
#include "mesh/Topology.h"
#include "mesh/Visibility.h"
#include "render/core/Dataset.h"
#include "render/core/RenderErrors.h"
#include "render/engine/Datasets.h"
#include "render/gl/Bindings.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/tets/TetRenderer.h"
#include "render/TetMeshes.h"
#include "render/reference/TetReference.h"
#include "render/tets/MeshPartition.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

/// A synthetic mesh (mesh::syntheticMesh `spec`) with its face adjacency, ready to draw.
std::shared_ptr<const TetMeshData> syntheticData(const std::string& spec) {
  mesh::TetMesh m = mesh::syntheticMesh(spec);
  mesh::Topology t = mesh::buildTopology(m);
  return std::make_shared<const TetMeshData>(std::move(m), std::move(t));
}

/// 96x80 frames of a transfer function transparent below 0.4 of the value range and a ramp above.
Scene partlyTransparentScene() {
  Scene scene;
  scene.width = 96;
  scene.height = 80;
  scene.transferFunction = TransferFunction({{0, {1, 0.5, 0, 0}}, {0.4, {1, 0.5, 0, 0}}, {1, {1, 1, 1, 0.6}}});
  scene.visibility = TetSort::Mpvo;  // projected; the ray caster's tests ask for it
  return scene;
}

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
  scene.visibility = TetSort::Mpvo;
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
  // The ray caster, along the grid's own axis (rays parallel to faces and edges, in their planes where a pixel's
  // centre falls on the lattice): the same opacity, every segment walked.
  scene.visibility = TetSort::Ray;
  scene.ert = 0;
  const image::ImageF rays = renderer.render(scene, &stats);
  EXPECT_EQ(stats.tetRayPasses, 2);
  EXPECT_NEAR(rays.pixel(32, 32)[0], want, 2e-3);
  test::expectClose(rays, image, 1.0 / 255, "tets-ray-axis");
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
// functions. The bound: the pre-integrated table's lookup (render/core/PreIntegration.h: at most 6e-3 in a segment's
// opacity near a transfer function's kinks, 2e-4 on average) and float arithmetic; measured 1/255 at most.
TEST(TetRenderer, FramesMatchTheExactReference) {
  auto data = syntheticData("ball,n=12");
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
      scene.visibility = TetSort::Mpvo;
      FrameStats stats;
      const image::ImageF gpu = renderer.render(scene, &stats);
      TetReferenceStats refStats;
      const image::ImageF exact =
          reference.render(TetReferenceParams::fromScene(scene, data->mesh, data->meanEdgeLength), &refStats);
      ASSERT_GT(test::meanBrightness(exact), 0.005) << tf << " " << v.name;
      test::expectClose(gpu, exact, 2.0 / 255, "tets-reference-" + tf + "-" + v.name);
      // A fragment per segment of positive length the reference found, up to the pixels on shared edges (with
      // every tet drawn: skipping leaves out those of transparent tets).
      scene.skipEmpty = false;
      renderer.render(scene, &stats);
      EXPECT_NEAR(double(stats.fragments), double(refStats.segments), 0.01 * double(refStats.segments)) << v.name;
    }
}

// Shading (Scene::shading): the grids' headlight with each tet's scalar gradient as the normal, exact for a
// pre-integrated segment (normal and eye direction are constant along it), so the GPU frame stays within the same
// bound of the exact reference; the shaded frame differs from the unshaded one, and by the headlight's rule: its
// ambient floor keeps at least 0.3 of the unshaded colour. Projected and ray cast (the gradient from the tet's
// vertices there) alike.
TEST(TetRenderer, ShadedFramesMatchTheExactReference) {
  auto data = syntheticData("ball,n=12");
  const TetReference reference(data->mesh);
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  for (const bool orthographic : {false, true})
    for (const TetSort sort : {TetSort::Mpvo, TetSort::Ray}) {
      SCOPED_TRACE(std::string(orthographic ? "orthographic, " : "perspective, ") + tetSortName(sort));
      Scene scene = partlyTransparentScene();
      scene.visibility = sort;
      scene.ert = 0;
      scene.camera.azimuth = 35;
      scene.camera.elevation = 25;
      scene.camera.orthographic = orthographic;
      const image::ImageF unshaded = renderer.render(scene);
      scene.shading = true;
      const image::ImageF gpu = renderer.render(scene);
      const TetReferenceParams params = TetReferenceParams::fromScene(scene, data->mesh, data->meanEdgeLength);
      ASSERT_TRUE(params.shading);
      const image::ImageF exact = reference.render(params);
      ASSERT_GT(test::meanBrightness(exact), 0.005);
      test::expectClose(gpu, exact, 2.0 / 255, orthographic ? "tets-shaded-ortho" : "tets-shaded");
      EXPECT_GT(image::compareImages(gpu, unshaded).maxAbs, 0.05) << "shading changed nothing";
      for (size_t i = 0; i < gpu.rgba.size(); i += 4)
        for (size_t c = 0; c < 3; ++c) ASSERT_GE(gpu.rgba[i + c], 0.3f * unshaded.rgba[i + c] - 2.0f / 255) << i;
    }
}

// Tets the transfer function makes transparent over their value range are left out: the same image, fewer tets.
TEST(TetRenderer, EmptyTetsAreSkippedWithoutChangingTheImage) {
  auto data = syntheticData("ball,n=12");
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  Scene scene = partlyTransparentScene();
  FrameStats skipped, all;
  const image::ImageF fast = renderer.render(scene, &skipped);
  scene.skipEmpty = false;
  const image::ImageF slow = renderer.render(scene, &all);
  ASSERT_GT(test::meanBrightness(slow), 0.005);
  EXPECT_EQ(all.tetsSkippedEmpty, 0);
  EXPECT_GT(skipped.tetsSkippedEmpty, all.tetsDrawn / 4);
  EXPECT_EQ(skipped.tetsDrawn + skipped.tetsSkippedEmpty, all.tetsDrawn);
  test::expectClose(fast, slow, 0.0, "tets-skip-empty");
}

// A mesh frame's cost is estimated before drawing (each drawn tet's projected bounding box, plus its vertex stage):
// never below the fragments it draws, within a small factor of them, lower when empty tets are skipped, and a frame
// above FrameOptions::maxSamples is refused naming the limit, with the renderer fine for the next frame.
TEST(TetRenderer, TheFrameCostIsEstimatedBeforeDrawingAndLimited) {
  auto data = syntheticData("ball,n=12");
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  Scene scene = partlyTransparentScene();
  for (const char* orbit : {"far", "close", "inside"}) {
    SCOPED_TRACE(orbit);
    const std::string o = orbit;
    scene.camera.distance = o == "far" ? 3.0 : o == "close" ? 1.1 : 0.3;  // bounding radii
    FrameStats skipped, all;
    scene.skipEmpty = true;
    renderer.render(scene, &skipped);
    scene.skipEmpty = false;
    renderer.render(scene, &all);
    ASSERT_GT(all.fragments, 0);
    EXPECT_GE(all.samplesEstimated, double(all.fragments));
    EXPECT_GE(skipped.samplesEstimated, double(skipped.fragments));
    EXPECT_LT(skipped.samplesEstimated, all.samplesEstimated);
    // Far from the eye, bounding boxes are at most a few times a tet's projection.
    if (o == "far") {
      EXPECT_LT(all.samplesEstimated, 8.0 * double(all.fragments));
    }
  }
  scene.camera.distance = 3.0;
  FrameStats measured;
  const image::ImageF before = renderer.render(scene, &measured);
  FrameOptions options;
  options.maxSamples = 0.5 * measured.samplesEstimated;
  try {
    renderer.render(scene, nullptr, options);
    ADD_FAILURE() << "a mesh frame above the limit was drawn";
  } catch (const RenderLimitError& e) {
    EXPECT_NE(std::string(e.what()).find("above the limit"), std::string::npos) << e.what();
  }
  options.maxSamples = 2 * measured.samplesEstimated;
  test::expectClose(renderer.render(scene, nullptr, options), before, 0.0, "tets-after-limit");
}

// A mesh larger than the GPU budget is streamed in batches of tets in visibility order: the same image; a budget
// below one batch and the table is refused naming both.
TEST(TetRenderer, AMeshLargerThanTheBudgetIsStreamedToTheSameImage) {
  auto data = syntheticData("ball,n=20");
  ASSERT_GT(data->mesh.tets.size(), 3 * 4096u);
  Scene scene;
  scene.width = 96;
  scene.height = 80;
  scene.transferFunction = TransferFunction::load("hot");
  scene.visibility = TetSort::Mpvo;
  TetRenderer resident(test::context(), data, TetRenderer::bytesFor(data->mesh.tets.size()));
  EXPECT_FALSE(resident.streamed());
  TetRenderer streamed(test::context(), data, TetRenderer::minimumBytes() + 1000);
  EXPECT_TRUE(streamed.streamed());
  EXPECT_LE(streamed.gpuBytes(), TetRenderer::minimumBytes() + 1000);
  FrameStats one, many;
  const image::ImageF want = resident.render(scene, &one);
  ASSERT_GT(test::meanBrightness(want), 0.01);
  test::expectClose(streamed.render(scene, &many), want, 0.0, "tets-streamed");
  EXPECT_EQ(one.batches, 1);
  EXPECT_GE(many.batches, 3);
  EXPECT_EQ(many.tetsDrawn, one.tetsDrawn);
  try {
    TetRenderer tooSmall(test::context(), data, TetRenderer::minimumBytes() - 1);
    FAIL() << "a budget below one batch must be refused";
  } catch (const RenderInputError& e) {
    EXPECT_NE(std::string(e.what()).find("holds no batch"), std::string::npos) << e.what();
  }
}

// A mesh frame given up part way (between its draws) throws FrameCancelled, and the next frame is a fresh renderer's.
TEST(TetRenderer, ACancelledFrameLeavesTheNextOneIntact) {
  auto data = syntheticData("ball,n=48");  // several draws of tets
  Scene scene;
  scene.width = 64;
  scene.height = 48;
  scene.transferFunction = TransferFunction::load("hot");
  scene.visibility = TetSort::Mpvo;
  for (bool streamed : {false, true}) {
    TetRenderer renderer(test::context(), data,
                         streamed ? TetRenderer::minimumBytes() : TetRenderer::bytesFor(data->mesh.tets.size()));
    ASSERT_EQ(renderer.streamed(), streamed);
    int asked = 0;
    FrameOptions options;
    options.cancelled = [&] { return ++asked > 2; };  // the sort's check and one draw pass, then give up
    EXPECT_THROW(renderer.render(scene, nullptr, options), FrameCancelled);
    EXPECT_GT(asked, 2);
    TetRenderer fresh(test::context(), data, size_t(512) << 20);
    test::expectClose(renderer.render(scene), fresh.render(scene), 0.0, "tets-after-cancel");
  }
}

/// A cube of Kuhn cells with a hollow: the cells whose centres lie within `radius` of a point off the centre are
/// left out, so that rays cross the hollow and tets on its far side are hidden by tets they share no face with.
std::shared_ptr<const TetMeshData> hollowCube(int n, double radius) {
  mesh::TetMesh grid = mesh::test::kuhnGrid(n, n, n);
  mesh::TetMesh m;
  m.points = grid.points;
  m.scalars = grid.scalars;
  m.field = grid.field;
  const glm::dvec3 hollow(0.45 * n, 0.55 * n, 0.5 * n);
  for (const mesh::Tet& t : grid.tets) {
    glm::dvec3 c(0.0);
    for (uint32_t v : t) c += glm::dvec3(grid.points[v]);
    if (glm::length(0.25 * c - hollow) > radius) m.tets.push_back(t);
  }
  for (float& s : m.scalars) s = std::abs(s);
  mesh::Topology t = mesh::buildTopology(m);
  return std::make_shared<const TetMeshData>(std::move(m), std::move(t));
}

// Non-convex meshes are where MPVO needs care: across the hollow, the tets behind are hidden by tets they share no
// face with, so the adjacency says nothing of their order. The walk takes the free tets nearest first (and so does
// the centroid sort everywhere); both frames stay close to the exact reference, MPVO the closer, and on the convex
// cube both are exact up to the table's lookups. The ray caster crosses the hollow in a pass of its own (an inner
// boundary: the ray leaves the mesh and enters it again) and is exact in its order whatever the mesh's shape.
TEST(TetRenderer, NonConvexMeshOrdersAgainstTheReference) {
  auto data = hollowCube(10, 3.2);
  const TetReference reference(data->mesh);
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  Scene scene;
  scene.width = 96;
  scene.height = 80;
  scene.transferFunction = TransferFunction::load("hot");
  scene.ert = 0;
  double worst[3] = {1e9, 1e9, 1e9};
  for (double azimuth : {0.0, 40.0, 100.0, 210.0}) {
    scene.camera.azimuth = azimuth;
    const image::ImageF exact =
        reference.render(TetReferenceParams::fromScene(scene, data->mesh, data->meanEdgeLength));
    ASSERT_GT(test::meanBrightness(exact), 0.005);
    for (TetSort sort : {TetSort::Mpvo, TetSort::Centroid, TetSort::Ray}) {
      scene.visibility = sort;
      FrameStats stats;
      const double psnr = image::compareImages(renderer.render(scene, &stats), exact).psnr;
      worst[int(sort)] = std::min(worst[int(sort)], psnr);
      std::printf("hollow cube, azimuth %.0f, %s: %.1f dB against the reference\n", azimuth, tetSortName(sort), psnr);
      if (sort == TetSort::Ray) {
        EXPECT_GE(stats.tetRayPasses, 3) << azimuth;
      }
    }
  }
  // Measured: MPVO 73.2-77.4 dB, centroid 72.0-77.2 dB, the ray caster as MPVO over these views.
  EXPECT_GT(worst[int(TetSort::Mpvo)], 60.0);
  EXPECT_GT(worst[int(TetSort::Centroid)], 55.0);
  EXPECT_GE(worst[int(TetSort::Mpvo)], worst[int(TetSort::Centroid)]);
  EXPECT_GT(worst[int(TetSort::Ray)], worst[int(TetSort::Mpvo)] - 1.0);
}

// The adjacency ray caster (TetSort::Ray) against the exact reference, on the staircase ball (non-convex: rays leave
// it and enter again, a pass each), perspective from outside, close up and orthographic, two transfer functions,
// without termination: the same bound as projected tets (the same segments, the same table). It walks a segment
// per tet the reference crosses, up to the pixels on shared edges.
TEST(TetRayCaster, FramesMatchTheExactReference) {
  auto data = syntheticData("ball,n=12");
  const TetReference reference(data->mesh);
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  CameraSpec orbit, close, orthographic;
  orbit.azimuth = 35;
  orbit.elevation = 25;
  close.distance = 1.3;
  orthographic.orthographic = true;
  orthographic.azimuth = 90;
  orthographic.elevation = 0;
  int64_t mostPasses = 0;
  for (const std::string tf : {"hot", "ct-bone"})
    for (const CameraSpec& camera : {orbit, close, orthographic}) {
      SCOPED_TRACE(tf + (camera.orthographic ? ", orthographic" : camera.distance ? ", close" : ", orbit"));
      Scene scene;
      scene.width = 96;
      scene.height = 80;
      scene.camera = camera;
      scene.transferFunction = TransferFunction::load(tf);
      scene.visibility = TetSort::Ray;
      scene.ert = 0;
      FrameStats stats;
      const image::ImageF gpu = renderer.render(scene, &stats);
      TetReferenceStats refStats;
      const image::ImageF exact =
          reference.render(TetReferenceParams::fromScene(scene, data->mesh, data->meanEdgeLength), &refStats);
      ASSERT_GT(test::meanBrightness(exact), 0.005);
      test::expectClose(gpu, exact, 2.0 / 255, "tets-ray-reference-" + tf);
      ASSERT_GE(stats.tetRayPasses, 2);  // a pass, and the entry pass that found nothing more
      EXPECT_EQ(stats.tetsDrawn, 0);
      EXPECT_EQ(stats.msSorting, 0.0);
      EXPECT_EQ(stats.samplesTerminated, 0);
      EXPECT_NEAR(double(stats.samples), double(refStats.segments), 0.01 * double(refStats.segments));
      mostPasses = std::max(mostPasses, stats.tetRayPasses);
    }
  EXPECT_GE(mostPasses, 3) << "no ray left the staircase ball and entered it again";
}

// Early ray termination (Scene::ert) on the ray caster: with a nearly opaque transfer function rays stop early, fewer
// segments are walked, and the image differs from the whole integral by at most 1 - ert.
TEST(TetRayCaster, EarlyTerminationStopsRaysWithinItsBound) {
  auto data = syntheticData("ball,n=16");
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  Scene scene;
  scene.width = 96;
  scene.height = 80;
  scene.transferFunction = TransferFunction({{0, {1, 0.6, 0.2, 0.6}}, {1, {0.2, 0.6, 1, 0.9}}});
  scene.visibility = TetSort::Ray;
  scene.ert = 0;
  FrameStats whole, stopped;
  const image::ImageF all = renderer.render(scene, &whole);
  scene.ert = 0.99;
  const image::ImageF early = renderer.render(scene, &stopped);
  EXPECT_EQ(whole.samplesTerminated, 0);
  EXPECT_GT(stopped.samplesTerminated, whole.fragments / 4);
  EXPECT_LT(double(stopped.samples), 0.8 * double(whole.samples));
  test::expectClose(early, all, 0.01 + 1e-5, "tets-ray-ert");
  EXPECT_GT(image::compareImages(early, all).maxAbs, 0.0) << "termination changed nothing: a test that cannot fail";
}

// Where rays cannot start outside the mesh (the eye within its box), or with the null fragment program, the frame is
// drawn projected in MPVO order instead, and says so; a frame given up part way (between passes or bands of a pass)
// throws FrameCancelled and the next is whole; the frame cost's estimate bounds the segments.
TEST(TetRayCaster, FallsBackWhereItCannotStartAndCancelsPartWay) {
  auto data = syntheticData("ball,n=12");
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  Scene scene = partlyTransparentScene();
  scene.visibility = TetSort::Ray;
  FrameStats stats;
  const image::ImageF outside = renderer.render(scene, &stats);
  EXPECT_GE(stats.tetRayPasses, 2);
  EXPECT_GE(stats.samplesEstimated, double(stats.samples));
  EXPECT_GT(renderer.gpuBytes(), TetRenderer::bytesFor(data->mesh.tets.size()));  // the ray caster's buffers
  scene.camera.distance = 0.3;                                                    // bounding radii: within the box
  const image::ImageF inside = renderer.render(scene, &stats);
  EXPECT_EQ(stats.tetRayPasses, 0);
  EXPECT_GT(stats.tetsDrawn, 0);
  scene.visibility = TetSort::Mpvo;
  test::expectClose(inside, renderer.render(scene), 0.0, "tets-ray-inside");
  scene.visibility = TetSort::Ray;
  scene.camera.distance.reset();
  FrameOptions roofline;
  roofline.mode = RenderMode::Roofline;  // Carrard & Juliachs' null fragment program: projected tets only
  renderer.render(scene, &stats, roofline);
  EXPECT_EQ(stats.tetRayPasses, 0);
  EXPECT_GT(stats.tetsDrawn + stats.tetsSkippedEmpty, 0);
  // Given up in the first ray pass, after its first band of rows (asked before the pass and after each band).
  int asked = 0;
  FrameOptions options;
  options.cancelled = [&] { return ++asked > 2; };
  EXPECT_THROW(renderer.render(scene, nullptr, options), FrameCancelled);
  EXPECT_EQ(asked, 3);
  test::expectClose(renderer.render(scene), outside, 0.0, "tets-ray-after-cancel");
  // A budget without room for the ray caster beside the projected tets: projected.
  TetRenderer small(test::context(), data,
                    std::max(TetRenderer::bytesFor(data->mesh.tets.size()), TetRenderer::minimumBytes()));
  ASSERT_FALSE(small.streamed());
  small.render(scene, &stats);
  EXPECT_EQ(stats.tetRayPasses, 0);
}

// The ray caster's compute kernel (Scene::raycaster compute: an invocation per pixel compositing into the target
// itself) walks the same rays as its fragment kernel: the same frame, whole or a part's, plain or shaded, through
// passes that re-enter a non-convex mesh, with and without early termination; the stats name the kernel; a frame
// given up between its tiles throws FrameCancelled and the next is whole.
TEST(TetRayCaster, TheComputeKernelDrawsTheFragmentKernelsFrame) {
  auto data = syntheticData("ball,n=12");  // a staircase ball: rays leave and enter again
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  CameraSpec orbit, orthographic;
  orbit.azimuth = 35;
  orbit.elevation = 25;
  orthographic.orthographic = true;
  orthographic.azimuth = 90;
  orthographic.elevation = 0;
  const Box& b = data->bounds;
  const MeshPartBox part{{b.min.x, b.min.y, b.min.z}, {b.center().x, b.max.y, b.max.z}};  // the mesh's left half
  int64_t mostPasses = 0;
  for (const bool shading : {false, true})
    for (const double ert : {0.0, 0.99})
      for (const CameraSpec& camera : {orbit, orthographic})
        for (const bool inPart : {false, true}) {
          SCOPED_TRACE(std::string(shading ? "shaded" : "plain") + ", ert " + std::to_string(ert) +
                       (camera.orthographic ? ", orthographic" : ", orbit") + (inPart ? ", a part" : ""));
          Scene scene;
          scene.width = 90;  // not a multiple of the 8x8 workgroups
          scene.height = 70;
          scene.camera = camera;
          scene.transferFunction = TransferFunction::load("hot");
          scene.visibility = TetSort::Ray;
          scene.shading = shading;
          scene.ert = ert;
          FrameOptions options;
          if (inPart) options.meshPart = part;
          FrameStats fragmentStats, computeStats;
          scene.raycaster = RayCaster::Fragment;
          const image::ImageF fragment = renderer.render(scene, &fragmentStats, options);
          scene.raycaster = RayCaster::Compute;
          const image::ImageF compute = renderer.render(scene, &computeStats, options);
          ASSERT_GT(test::meanBrightness(fragment), 0.003);
          EXPECT_EQ(fragmentStats.raycaster, "fragment");
          EXPECT_EQ(computeStats.raycaster, "compute");
          EXPECT_EQ(computeStats.tetRayPasses, fragmentStats.tetRayPasses);
          EXPECT_EQ(computeStats.samples, fragmentStats.samples);
          EXPECT_EQ(computeStats.samplesTerminated, fragmentStats.samplesTerminated);
          test::expectClose(compute, fragment, 1e-6, "tets-ray-compute");
          mostPasses = std::max(mostPasses, computeStats.tetRayPasses);
        }
  EXPECT_GE(mostPasses, 3) << "no ray left the staircase ball and entered it again";

  Scene scene = partlyTransparentScene();
  scene.visibility = TetSort::Ray;
  FrameStats stats;
  renderer.render(scene, &stats);
  EXPECT_EQ(stats.raycaster, "fragment") << "auto keeps a mesh's fragment kernel until a GPU has measured both";
  scene.raycaster = RayCaster::Compute;
  const image::ImageF whole = renderer.render(scene);
  int asked = 0;
  FrameOptions options;
  options.cancelled = [&] { return ++asked > 2; };  // before the pass, after its first tile, then given up
  EXPECT_THROW(renderer.render(scene, nullptr, options), FrameCancelled);
  EXPECT_EQ(asked, 3);
  test::expectClose(renderer.render(scene), whole, 0.0, "tets-ray-compute-after-cancel");
}

/// The strip tet.vert.glsl makes for each tet, captured by transform feedback (rasterizer discarded): two triangles
/// per tet, in normalised device coordinates.
std::vector<std::array<glm::vec2, 6>> capturedStrips(const std::vector<glm::vec4>& vertices,
                                                     const glm::mat4& viewProj) {
  const Gl& gl = test::context().gl();
  ProgramSources sources = ProgramSources::fromFiles("capture tet", {{GL_VERTEX_SHADER, "tet.vert.glsl"}});
  sources.feedbackVaryings = {"gl_Position"};
  const Program program(gl, sources);
  const size_t tets = vertices.size() / 4;
  std::vector<uint32_t> order(tets);
  for (size_t t = 0; t < tets; ++t) order[t] = uint32_t(t);
  Buffer tetBuffer(gl), orderBuffer(gl), feedback(gl);
  tetBuffer.allocate(GL_SHADER_STORAGE_BUFFER, vertices.size() * sizeof(glm::vec4), vertices.data(), GL_STATIC_DRAW);
  orderBuffer.allocate(GL_SHADER_STORAGE_BUFFER, order.size() * 4, order.data(), GL_STATIC_DRAW);
  feedback.allocate(GL_TRANSFORM_FEEDBACK_BUFFER, tets * 6 * sizeof(glm::vec4), nullptr, GL_STREAM_READ);
  gl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_TET_VERTICES, tetBuffer.id());
  gl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_TET_ORDER, orderBuffer.id());
  gl.glBindBufferBase(GL_TRANSFORM_FEEDBACK_BUFFER, 0, feedback.id());
  program.set(program.uniformLocation("uViewProj"), viewProj);
  program.set(program.uniformLocation("uWindowLo"), 0.0f);
  program.set(program.uniformLocation("uWindowScale"), 1.0f);
  program.use();
  const VertexArray empty(gl);
  empty.bind();
  const Framebuffer target = Framebuffer::withColor(gl, 4, 4, GL_RGBA32F);  // a surfaceless context has none
  target.bind();
  gl.glEnable(GL_RASTERIZER_DISCARD);
  gl.glBeginTransformFeedback(GL_TRIANGLES);
  gl.glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, GLsizei(tets));
  gl.glEndTransformFeedback();
  gl.glDisable(GL_RASTERIZER_DISCARD);
  std::vector<glm::vec4> out(tets * 6);
  feedback.read(0, out.size() * sizeof(glm::vec4), out.data());
  checkGlError(gl, "capturedStrips");
  std::vector<std::array<glm::vec2, 6>> strips(tets);
  for (size_t t = 0; t < tets; ++t)
    for (int i = 0; i < 6; ++i) strips[t][size_t(i)] = glm::vec2(out[6 * t + size_t(i)]) / out[6 * t + size_t(i)].w;
  return strips;
}

double cross2(glm::dvec2 a, glm::dvec2 b, glm::dvec2 c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

/// The area of the convex hull of four points (the largest of the quadrilaterals' and triangles' areas would do,
/// but the hull is computed directly: gift wrapping).
double hullArea(const std::array<glm::dvec2, 4>& p) {
  std::vector<glm::dvec2> pts(p.begin(), p.end());
  std::sort(pts.begin(), pts.end(), [](auto a, auto b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  std::vector<glm::dvec2> hull;
  for (int pass = 0; pass < 2; ++pass) {
    const size_t start = hull.size();
    for (const glm::dvec2& q : pts) {
      while (hull.size() >= start + 2 && cross2(hull[hull.size() - 2], hull.back(), q) <= 0) hull.pop_back();
      hull.push_back(q);
    }
    hull.pop_back();
    std::reverse(pts.begin(), pts.end());
  }
  double area = 0;
  for (size_t i = 0; i < hull.size(); ++i) {
    const glm::dvec2 a = hull[i], b = hull[(i + 1) % hull.size()];
    area += a.x * b.y - a.y * b.x;
  }
  return 0.5 * std::abs(area);
}

// The strip covers exactly the tet's projection (the convex hull of its projected vertices) in every case: a
// quadrilateral, a triangle with a vertex inside, a vertex behind the eye (the whole viewport), a degenerate tet
// (nothing), and random tets under a perspective camera, checked against the hull computed on the CPU.
TEST(TetRenderer, StripsCoverExactlyTheProjection) {
  const glm::mat4 ortho = glm::mat4(1.0f);  // world x, y are the projection's
  std::vector<glm::vec4> v = {
      // a quadrilateral: two opposite edges cross in projection
      {-0.5f, -0.5f, 0.0f, 0},
      {0.5f, 0.5f, 0.2f, 0},
      {0.5f, -0.5f, 0.6f, 0},
      {-0.5f, 0.5f, 0.4f, 0},
      // a triangle, the fourth vertex projecting inside it
      {-0.6f, -0.4f, 0.0f, 0},
      {0.6f, -0.4f, 0.0f, 0},
      {0.0f, 0.7f, 0.0f, 0},
      {0.0f, 0.0f, 0.5f, 0},
      // degenerate: four points in a plane
      {0, 0, 0, 0},
      {0.5f, 0, 0, 0},
      {0, 0.5f, 0, 0},
      {0.5f, 0.5f, 0, 0},
  };
  auto strips = capturedStrips(v, ortho);
  ASSERT_EQ(strips.size(), 3u);
  auto stripArea = [](const std::array<glm::vec2, 6>& s) {
    return 0.5 * (std::abs(cross2(s[0], s[1], s[2])) + std::abs(cross2(s[3], s[4], s[5])));
  };
  auto projected = [&](size_t t, const glm::mat4& m) {
    std::array<glm::dvec2, 4> p;
    for (size_t i = 0; i < 4; ++i) {
      const glm::vec4 c = m * glm::vec4(glm::vec3(v[4 * t + i]), 1.0f);
      p[i] = glm::dvec2(c) / double(c.w);
    }
    return p;
  };
  EXPECT_NEAR(stripArea(strips[0]), hullArea(projected(0, ortho)), 1e-6);
  EXPECT_NEAR(stripArea(strips[0]), 1.0, 1e-6);
  EXPECT_NEAR(stripArea(strips[1]), hullArea(projected(1, ortho)), 1e-6);
  for (const glm::vec2& corner : strips[2]) EXPECT_GT(corner.x, 1.0f) << "a degenerate tet draws nothing";

  // Random tets under a perspective camera, one with a vertex behind the eye.
  const glm::mat4 perspective = glm::perspective(glm::radians(40.0f), 1.0f, 0.1f, 10.0f) *
                                glm::lookAt(glm::vec3(0, 0, 3), glm::vec3(0), glm::vec3(0, 1, 0));
  v.clear();
  uint32_t seed = 12345;
  auto rnd = [&] {
    seed = seed * 1664525u + 1013904223u;
    return float(seed >> 8) / float(1 << 24) * 2.0f - 1.0f;
  };
  for (int t = 0; t < 200; ++t)
    for (int i = 0; i < 4; ++i) v.push_back({rnd(), rnd(), rnd(), 0});
  v.insert(v.end(), {{0, 0, 0, 0}, {0.5f, 0, 0, 0}, {0, 0.5f, 0, 0}, {0.1f, 0.1f, 5.0f, 0}});  // past the eye
  strips = capturedStrips(v, perspective);
  for (size_t t = 0; t < 200; ++t) {
    const double hull = hullArea(projected(t, perspective));
    EXPECT_NEAR(stripArea(strips[t]), hull, 1e-5 * std::max(1.0, hull)) << "tet " << t;
    for (const glm::vec2& corner : strips[t]) {
      bool isVertex = false;
      for (const glm::dvec2& p : projected(t, perspective))
        isVertex = isVertex || glm::length(glm::dvec2(corner) - p) < 1e-5;
      EXPECT_TRUE(isVertex) << "tet " << t << ": the strip's corners are the projected vertices";
    }
  }
  EXPECT_NEAR(stripArea(strips[200]), 4.0, 1e-6) << "a vertex behind the eye: the whole viewport";
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
  // A mesh that fits its host budget is held whole (a larger one is paged: test_tet_paging.cpp); one whose points
  // alone exceed it is refused, naming both sizes.
  EXPECT_EQ(openDataset("ball", dir / "ball", size_t(1) << 30)->kind(), "tet-mesh");
  try {
    openDataset("ball", dir / "ball", 1000);
    ADD_FAILURE() << "a mesh above its host budget was opened";
  } catch (const RenderLimitError& e) {
    EXPECT_NE(std::string(e.what()).find("above the host budget it may use, 1000 bytes"), std::string::npos)
        << e.what();
  }
  r = test::runVoxbrick("prep " + (dir / "ball.vtk").string() + " -q -o " + (dir / "ball").string());
  EXPECT_NE(r.exitCode, 0) << "an existing store is replaced only with --force";
  r = test::runVoxbrick("prep " + (dir / "ball.vtk").string() + " -q --force -o " + (dir / "ball").string());
  EXPECT_EQ(r.exitCode, 0) << r.output;
  r = test::runVoxbrick("render " + (dir / "ball").string() + " --size 64x48 --tf hot -q -o " +
                        (dir / "ball.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("tet segments ray cast"), std::string::npos) << r.output;  // the default
  r = test::runVoxbrick("render " + (dir / "ball").string() + " --size 64x48 --tf hot -q --visibility mpvo -o " +
                        (dir / "mpvo.png").string());
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


// Sort-last parts of a mesh ------------------------------------------------------------------------------------------

/// `data` split `parts` ways by its cells (partitionMesh), each part drawn alone by `renderer` with
/// FrameOptions::meshPart, joined front to back for `scene` (compositeSerial) and finished over its background; each
/// part's frame and stats into `frames` and `stats` when given.
image::ImageF joinedMeshParts(TetRenderer& renderer, const TetMeshData& data, const Scene& scene, int parts,
                              std::vector<image::ImageF>* frames = nullptr, std::vector<FrameStats>* stats = nullptr) {
  const MeshPartition partition = partitionMesh(cellWeights(data.mesh), data.bounds, parts);
  std::vector<image::ImageF> drawn;
  for (const MeshPartBox& box : partition.boxes) {
    FrameOptions options;
    options.meshPart = box;
    FrameStats s;
    drawn.push_back(renderer.render(scene, &s, options));
    if (stats) stats->push_back(s);
  }
  if (frames) *frames = drawn;
  return finishPartial(compositeSerial(drawn, partsFrontToBack(partition, meshPartView(scene, data))), scene);
}

// The parts of a mesh, each drawn alone (only its cells, every ray clipped to its box, premultiplied), joined in
// their front-to-back order give the whole frame within 1/255 for 1 to 5 parts: ray cast (the staircase ball,
// non-convex, from outside, orthographic, shaded), and projected (the camera inside the mesh's box, where the whole
// frame is projected too, and MPVO asked for), each part's frame saying how it was clipped.
TEST(TetRenderer, MeshPartsJoinedInOrderGiveTheWholeFrame) {
  auto ball = syntheticData("ball,n=10");
  auto box = syntheticData("box,n=6");
  TetRenderer ballRenderer(test::context(), ball, size_t(256) << 20);
  TetRenderer boxRenderer(test::context(), box, size_t(256) << 20);
  struct Case {
    std::string name;
    bool onBall;
    TetSort visibility;
    CameraSpec camera;
    bool shading = false;
    std::string clip;  // FrameStats::tetPart expected
  };
  CameraSpec orbit, orthographic, inside;
  orbit.azimuth = 35;
  orbit.elevation = 25;
  orthographic.orthographic = true;
  orthographic.azimuth = 200;
  orthographic.elevation = -40;
  inside.azimuth = 35;
  inside.elevation = 25;
  inside.distance = 0.3;  // bounding radii: within the box
  inside.fovY = 75;
  const std::vector<Case> cases = {{"ray-orbit", true, TetSort::Ray, orbit, false, "raycast"},
                                   {"ray-orthographic", true, TetSort::Ray, orthographic, false, "raycast"},
                                   {"ray-shaded", true, TetSort::Ray, orbit, true, "raycast"},
                                   {"inside", false, TetSort::Ray, inside, false, "projected"},
                                   {"mpvo", false, TetSort::Mpvo, orbit, false, "projected"}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    Scene scene;
    scene.width = 72;
    scene.height = 64;
    scene.camera = c.camera;
    scene.transferFunction = TransferFunction::load("hot");
    scene.visibility = c.visibility;
    scene.shading = c.shading;
    TetRenderer& renderer = c.onBall ? ballRenderer : boxRenderer;
    const TetMeshData& data = c.onBall ? *ball : *box;
    FrameStats wholeStats;
    const image::ImageF whole = renderer.render(scene, &wholeStats);
    ASSERT_GT(test::meanBrightness(whole), 0.01);
    ASSERT_TRUE(wholeStats.tetPart.empty());
    for (int parts = 1; parts <= 5; ++parts) {
      std::vector<image::ImageF> frames;
      std::vector<FrameStats> stats;
      const image::ImageF joined = joinedMeshParts(renderer, data, scene, parts, &frames, &stats);
      test::expectClose(joined, whole, 1.0 / 255, "tets-parts-" + c.name + "-" + std::to_string(parts));
      int64_t drawn = 0;
      const MeshPartition partition = partitionMesh(cellWeights(data.mesh), data.bounds, parts);
      for (size_t p = 0; p < stats.size(); ++p) {
        EXPECT_EQ(stats[p].tetPart, c.clip) << "part " << p;
        // Every pixel the part drew lies in its footprint (what the compositor reads of it).
        const PixelRect active = activeRect(frames[p]);
        const PixelRect footprint = meshPartFootprint(partition.boxes[p], data, scene, scene.width, scene.height);
        EXPECT_TRUE(active.empty() || (active.x0 >= footprint.x0 && active.y0 >= footprint.y0 &&
                                       active.x1 <= footprint.x1 && active.y1 <= footprint.y1))
            << "part " << p << " drew outside its footprint";
        drawn += stats[p].tetsDrawn;
        if (c.clip == "projected" && parts > 1) {
          EXPECT_LT(stats[p].tetsDrawn, wholeStats.tetsDrawn) << "part " << p << " drew cells outside its box";
        }
      }
      if (c.clip == "projected") {
        EXPECT_GE(drawn, wholeStats.tetsDrawn) << "every cell drawn by some part";
      }
      if (parts > 1) {
        EXPECT_GT(image::compareImages(finishPartial(frames[0], scene), whole).maxAbs, 1.0 / 255)
            << "one part drew the whole frame: a test that cannot fail";
      }
    }
  }
}

// A cell straddling a cut is drawn by both parts, each integrating its rays only on its own side, so that it counts
// once in all: a single tet cut through its middle, ray cast and projected. Drawn unclipped by either part, the
// joined frame would be more opaque than the whole one.
TEST(TetRenderer, ACellStraddlingACutIsDrawnOnceInAll) {
  mesh::TetMesh m = test::cornerTet([](const glm::dvec3& p) { return p.x + 0.5 * p.y; });
  mesh::Topology t = mesh::buildTopology(m);
  auto data = std::make_shared<const TetMeshData>(std::move(m), std::move(t));
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  const MeshPartition partition = partitionMesh(cellWeights(data->mesh), data->bounds, 2);
  const MeshPartition::Node& cut = partition.nodes.at(0);
  ASSERT_GE(cut.axis, 0);
  ASSERT_GT(cut.position, data->bounds.min[cut.axis] + 0.1);
  ASSERT_LT(cut.position, data->bounds.max[cut.axis] - 0.1) << "the cut goes through the tet";
  for (const TetSort visibility : {TetSort::Ray, TetSort::Mpvo}) {
    SCOPED_TRACE(tetSortName(visibility));
    Scene scene;
    scene.width = 64;
    scene.height = 64;
    scene.transferFunction = TransferFunction({{0, {1, 0.6, 0.2, 0.6}}, {1, {0.2, 0.6, 1, 0.6}}}, 0.5);
    scene.visibility = visibility;
    const image::ImageF whole = renderer.render(scene);
    std::vector<image::ImageF> frames;
    const image::ImageF joined = joinedMeshParts(renderer, *data, scene, 2, &frames);
    test::expectClose(joined, whole, 1.0 / 255, "tets-straddling");
    // Both parts drew the tet, each less opaque than the whole where both did.
    const image::ImageF wholePremultiplied = [&] {
      FrameOptions one;
      one.meshPart = MeshPartBox{{-10, -10, -10}, {10, 10, 10}};
      return renderer.render(scene, nullptr, one);
    }();
    int both = 0;
    for (int y = 0; y < scene.height; ++y)
      for (int x = 0; x < scene.width; ++x) {
        const float a0 = frames[0].pixel(x, y)[3], a1 = frames[1].pixel(x, y)[3];
        const float a = wholePremultiplied.pixel(x, y)[3];
        if (a0 > 0.01f && a1 > 0.01f) {
          ++both;
          EXPECT_LT(std::max(a0, a1), a - 0.005f) << "pixel " << x << ", " << y;
          // Front over back: 1 - (1 - a0)(1 - a1) is the whole's opacity.
          EXPECT_NEAR(1 - (1 - a0) * (1 - a1), a, 2.0 / 255) << "pixel " << x << ", " << y;
        }
      }
    EXPECT_GT(both, 20) << "the cut crosses the tet's projection";
  }
}

// A part given as a grid's box, a mesh part that is no box, and a part of a null-fragment frame are refused.
TEST(TetRenderer, BadMeshPartsAreRefused) {
  auto data = syntheticData("box,n=2");
  TetRenderer renderer(test::context(), data, size_t(256) << 20);
  Scene scene = partlyTransparentScene();
  FrameOptions options;
  options.meshPart = MeshPartBox{{0, 0, 0}, {-1, 1, 1}};
  EXPECT_THROW(renderer.render(scene, nullptr, options), RenderInputError);
  options.meshPart = MeshPartBox{{0, 0, 0}, {std::nan(""), 1, 1}};
  EXPECT_THROW(renderer.render(scene, nullptr, options), RenderInputError);
  options.meshPart = MeshPartBox{{0, 0, 0}, {1, 1, 1}};
  options.mode = RenderMode::Roofline;
  EXPECT_THROW(renderer.render(scene, nullptr, options), RenderInputError);
  options.mode = RenderMode::Normal;
  EXPECT_NO_THROW(renderer.render(scene, nullptr, options));
  // A part with no cell in it: transparent, nothing drawn.
  options.meshPart = MeshPartBox{{5, 5, 5}, {6, 6, 6}};
  FrameStats stats;
  const image::ImageF empty = renderer.render(scene, &stats, options);
  EXPECT_EQ(activeRect(empty).pixels(), 0);
  EXPECT_EQ(stats.tetsDrawn, 0);
}

}  // namespace
}  // namespace voxbrick::render
