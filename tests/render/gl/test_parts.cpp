// Sort-last rendering's renderer side: the parts of a partition, each drawn alone with FrameOptions::part (only the
// samples owned inside its box, premultiplied, no background), joined with the serial compositor in the partition's
// front-to-back order and finished over the background, give the whole frame within 1/255, for N = 1..5 parts, with
// the ray caster, slicing and slabs, on several fields and cameras and with level of detail; a part pages only its
// own bricks; a part on a mesh is refused.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "image/Image.h"
#include "mesh/MeshStoreFixtures.h"
#include "render/core/RenderErrors.h"
#include "render/engine/Datasets.h"
#include "render/engine/RenderEngine.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/tets/TetRenderer.h"
#include "render/volume/BrickStoreDataset.h"
#include "render/volume/Partition.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::expectClose;
using test::meanBrightness;
using test::prep;
using test::ScratchDir;

enum class Technique { RayCast, Slicing, Slabs, RayCastCompute };

/// A small frame (72x64) of lodScene's camera with `tf` and `technique`: the ray caster (the default; its fragment
/// kernel, or its compute kernel), slicing of whole bricks (slicingScene, whose whole frame shares rasterised faces
/// where a part's owns exactly) or texture slabs.
Scene sceneFor(Technique technique, const std::string& tf) {
  Scene scene = technique == Technique::Slicing ? test::slicingScene(tf) : test::lodScene(Scene{}.lod);
  scene.width = 72;
  scene.height = 64;
  scene.transferFunction = TransferFunction::load(tf);
  if (technique == Technique::Slabs) scene.raycast = false;
  scene.raycaster = technique == Technique::RayCastCompute ? RayCaster::Compute : RayCaster::Fragment;
  return scene;
}

/// The parts `boxes` drawn one by one by `renderer` with `options` (and each box as FrameOptions::part), and the
/// stats of each.
struct DrawnParts {
  std::vector<image::ImageF> frames;
  std::vector<FrameStats> stats;
  int64_t bricksDrawn() const {
    int64_t n = 0;
    for (const FrameStats& s : stats) n += s.bricksDrawn;
    return n;
  }
};
DrawnParts drawParts(VolumeRenderer& renderer, const Scene& scene, const std::vector<PartBox>& boxes,
                     FrameOptions options = {}) {
  DrawnParts out;
  for (const PartBox& box : boxes) {
    options.part = box;
    out.stats.emplace_back();
    out.frames.push_back(renderer.render(scene, &out.stats.back(), options));
  }
  return out;
}

/// Expects the parts, composited in `order` (compositeSerial) and finished over the background, to be the drawing
/// `whole` of `scene` from `s` within 1/255 (expectSameDrawing).
void expectJoinedIsWhole(const std::vector<image::ImageF>& parts, const std::vector<int>& order,
                         const image::ImageF& whole, const store::BrickStore& s, const Scene& scene,
                         const std::string& what) {
  test::expectSameDrawing(finishPartial(compositeSerial(parts, order), scene), whole, 1.0 / 255, s, scene, what);
}

/// Every pixel a part drew lies in its footprint (what the compositor reads of it).
void expectWithinFootprint(const image::ImageF& part, const PixelRect& footprint, const std::string& what) {
  const PixelRect drawn = activeRect(part);
  if (drawn.empty()) return;
  EXPECT_TRUE(drawn.x0 >= footprint.x0 && drawn.y0 >= footprint.y0 && drawn.x1 <= footprint.x1 &&
              drawn.y1 <= footprint.y1)
      << what << ": drawn in [" << drawn.x0 << ", " << drawn.x1 << ") x [" << drawn.y0 << ", " << drawn.y1
      << "), footprint [" << footprint.x0 << ", " << footprint.x1 << ") x [" << footprint.y0 << ", " << footprint.y1
      << ")";
}

/// The whole frame, and the parts of an N-part partition drawn one by one, composited and finished.
void expectPartsGiveTheWholeFrame(const std::shared_ptr<const store::BrickStore>& s, const Scene& scene,
                                  const std::string& what, int minCoarsest = 0) {
  auto cache = std::make_shared<store::BrickCache>(s, size_t(256) << 20, 1);
  VolumeRenderer renderer(test::context(), cache, size_t(256) << 20);
  FrameStats wholeStats;
  const image::ImageF whole = renderer.render(scene, &wholeStats);
  ASSERT_GT(meanBrightness(whole), 0.01) << what << ": a frame that shows something";
  ASSERT_GE(wholeStats.levelCoarsest, minCoarsest) << what;
  for (int n = 1; n <= 5; ++n) {
    const Partition partition = partitionBricks(*s, n);
    const DrawnParts parts = drawParts(renderer, scene, partition.boxes);
    long long footprints = 0, cutFootprints = 0;
    for (int p = 0; p < n; ++p) {
      EXPECT_LE(parts.stats[size_t(p)].bricksDrawn, wholeStats.bricksDrawn) << what << ", part " << p << " of " << n;
      expectWithinFootprint(parts.frames[size_t(p)],
                            partFootprint(s->meta(), partition.boxes[size_t(p)], scene, scene.width, scene.height),
                            what + ", part " + std::to_string(p) + " of " + std::to_string(n));
      // Cut to the bricks the part drew (what the server reads).
      ASSERT_TRUE(parts.stats[size_t(p)].drawnBox.has_value()) << what;
      expectWithinFootprint(parts.frames[size_t(p)],
                            partFootprint(s->meta(), partition.boxes[size_t(p)], scene, scene.width, scene.height,
                                          parts.stats[size_t(p)].drawnBox),
                            what + ", part " + std::to_string(p) + " of " + std::to_string(n) + ", cut to its bricks");
      cutFootprints += partFootprint(s->meta(), partition.boxes[size_t(p)], scene, scene.width, scene.height,
                                     parts.stats[size_t(p)].drawnBox)
                           .pixels();
      footprints += partFootprint(s->meta(), partition.boxes[size_t(p)], scene, scene.width, scene.height).pixels();
    }
    if (n > 1 && what != "inside") {
      EXPECT_LT(footprints, (long long)n * scene.width * scene.height)
          << what << ", " << n << " parts: footprints no smaller than the frame, a check that cannot fail";
    }
    EXPECT_LE(cutFootprints, footprints) << what << ", " << n << " parts: cutting to the bricks drawn grew them";
    if (what == "sparse" && n > 1) {
      EXPECT_LT(cutFootprints, footprints) << n << " parts of a sparse field: nothing cut";
    }
    EXPECT_GE(parts.bricksDrawn(), wholeStats.bricksDrawn) << what << ", " << n << " parts: every brick in some part";
    expectJoinedIsWhole(parts.frames, partsFrontToBack(partition, partView(s->meta(), scene)), whole, *s, scene,
                        what + "-" + std::to_string(n) + "parts");
  }
}

/// The fields and cameras of the comparison: a smooth field with the MRI preset, a sparse field, the camera inside
/// the volume, an orthographic view, a coarse level of detail, and shading with pre-integration (where the technique
/// marches) over a transparent background.
void expectEveryCase(Technique technique) {
  ScratchDir dir;
  const auto blobs = prep("synthetic:blobs,n=64", dir / "b", 16);
  const auto sparse = prep("synthetic:sparse,n=64", dir / "s", 16);
  const Scene mri = sceneFor(technique, "mri");
  expectPartsGiveTheWholeFrame(blobs, mri, "mri");
  expectPartsGiveTheWholeFrame(sparse, sceneFor(technique, "sparse"), "sparse");
  for (const auto& [name, camera] : test::marchCameras(false)) {
    if (name != "inside" && name != "ortho") continue;  // the other two are mri's own camera and an axis view
    Scene view = mri;
    view.camera = camera;
    expectPartsGiveTheWholeFrame(blobs, view, name);
  }
  Scene lod = mri;
  lod.lod = 4;
  expectPartsGiveTheWholeFrame(blobs, lod, "lod", 1);
  Scene shaded = mri;
  shaded.shading = true, shaded.preIntegration = true, shaded.transparent = true;
  expectPartsGiveTheWholeFrame(blobs, shaded, "shaded");
}

TEST(Parts, RayCasterPartsCompositeToTheWholeFrame) { expectEveryCase(Technique::RayCast); }
TEST(Parts, ComputeRayCasterPartsCompositeToTheWholeFrame) { expectEveryCase(Technique::RayCastCompute); }
TEST(Parts, SlicingPartsCompositeToTheWholeFrame) { expectEveryCase(Technique::Slicing); }
TEST(Parts, SlabPartsCompositeToTheWholeFrame) { expectEveryCase(Technique::Slabs); }

TEST(Parts, ACoarseBrickCutByThePartsIsDrawnClippedByEach) {
  // Two parts split through level-1 bricks (at brick 1 and 3 of 4 along an axis): with a coarse level of detail both
  // parts draw the coarse bricks across the split, each clipped to its box.
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=64", dir / "b", 16);
  for (Technique technique : {Technique::RayCast, Technique::Slicing, Technique::Slabs}) {
    Scene scene = sceneFor(technique, "mri");
    scene.lod = 4;
    auto cache = std::make_shared<store::BrickCache>(s, size_t(256) << 20, 1);
    VolumeRenderer renderer(test::context(), cache, size_t(256) << 20);
    FrameStats wholeStats;
    const image::ImageF whole = renderer.render(scene, &wholeStats);
    ASSERT_GT(wholeStats.bricksCoarse, 0);
    for (int axis = 0; axis < 3; ++axis)
      for (int position : {16, 48}) {
        Partition partition;
        partition.nodes = {{axis, position, 1, 2, -1}, {-1, 0, -1, -1, 0}, {-1, 0, -1, -1, 1}};
        partition.boxes = {PartBox{{0, 0, 0}, {64, 64, 64}}, PartBox{{0, 0, 0}, {64, 64, 64}}};
        partition.boxes[0].hi[size_t(axis)] = position;
        partition.boxes[1].lo[size_t(axis)] = position;
        const DrawnParts parts = drawParts(renderer, scene, partition.boxes);
        const std::string what =
            "cut-" + std::to_string(int(technique)) + "-axis" + std::to_string(axis) + "-at" + std::to_string(position);
        EXPECT_GT(parts.bricksDrawn(), wholeStats.bricksDrawn)
            << what << ": a coarse brick across the split is drawn by both";
        expectJoinedIsWhole(parts.frames, partsFrontToBack(partition, partView(s->meta(), scene)), whole, *s, scene,
                            what);
      }
  }
}

TEST(Parts, PartsDrawnInSeveralBatchesStillComposite) {
  // An atlas of 6 bricks: the whole frame and each part are drawn batch by batch (levels fixed).
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=64", dir / "b", 16);
  const size_t gpuBudget = 6 * size_t(18 * 18 * 18) * sizeof(float);
  for (Technique technique : {Technique::RayCast, Technique::RayCastCompute, Technique::Slabs}) {
    Scene scene = sceneFor(technique, "mri");
    scene.lod = 0;
    auto cache = std::make_shared<store::BrickCache>(s, size_t(256) << 20, 1);
    VolumeRenderer renderer(test::context(), cache, gpuBudget);
    FrameStats wholeStats;
    const image::ImageF whole = renderer.render(scene, &wholeStats, test::batched());
    ASSERT_GT(wholeStats.batches, 1);
    const Partition partition = partitionBricks(*s, 3);
    const DrawnParts parts = drawParts(renderer, scene, partition.boxes, test::batched());
    int batched = 0;
    for (const FrameStats& stats : parts.stats) batched += stats.batches > 1;
    EXPECT_GT(batched, 0) << "a part drawn in several batches";
    expectJoinedIsWhole(parts.frames, partsFrontToBack(partition, partView(s->meta(), scene)), whole, *s, scene,
                        "batches-" + std::to_string(int(technique)));
  }
}

TEST(Parts, APartPagesOnlyItsOwnBricksAndKeepsNoBackground) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=64", dir / "b", 16);
  Scene scene = sceneFor(Technique::RayCast, "mri");
  scene.lod = 0;
  scene.background = {1, 1, 1};
  const Partition partition = partitionBricks(*s, 4);
  for (int p = 0; p < 4; ++p) {
    const PartBox& box = partition.boxes[size_t(p)];
    auto cache = std::make_shared<store::BrickCache>(s, size_t(256) << 20, 1);
    VolumeRenderer renderer(test::context(), cache, size_t(256) << 20);
    FrameOptions options;
    options.part = box;
    FrameStats stats;
    const image::ImageF partial = renderer.render(scene, &stats, options);
    // Level 0 only: the bricks paged are bricks inside the box.
    const int64_t inside =
        (box.hi[0] - box.lo[0]) / 16 * ((box.hi[1] - box.lo[1]) / 16) * ((box.hi[2] - box.lo[2]) / 16);
    EXPECT_GT(stats.bricksPagedIn, 0) << "part " << p;
    EXPECT_LE(stats.bricksPagedIn, inside) << "part " << p << " paged bricks of other parts";
    EXPECT_LE(stats.bricksDrawn, inside) << "part " << p;
    // No background: a pixel no sample reaches is transparent black, not white.
    EXPECT_EQ(partial.pixel(0, 0)[0], 0.0f);
    EXPECT_EQ(partial.pixel(0, 0)[3], 0.0f);
    for (size_t i = 0; i < partial.rgba.size(); i += 4)
      for (int c = 0; c < 3; ++c)
        ASSERT_LE(partial.rgba[i + size_t(c)], partial.rgba[i + 3] + 1e-5f) << "premultiplied";
  }
}

TEST(Parts, StandInsFillInToThePartsExactFrame) {
  // From a cold cache each part stands in for what it lacks, pages only its own bricks (and their ancestors), and
  // once they are paged draws its exact frame; the refined parts composite to the whole frame.
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=64", dir / "b", 16);
  Scene scene = sceneFor(Technique::RayCast, "mri");
  scene.lod = 0;
  const Partition partition = partitionBricks(*s, 3);
  std::vector<image::ImageF> parts;
  FrameOptions streamed;
  streamed.standIns = true;
  for (const PartBox& box : partition.boxes) {
    auto cache = std::make_shared<store::BrickCache>(s, size_t(256) << 20, 2);
    VolumeRenderer renderer(test::context(), cache, size_t(256) << 20);
    streamed.part = box;
    FrameStats first, refined, exact;
    renderer.render(scene, &first, streamed);
    EXPECT_GT(first.bricksStandIn, 0);
    test::waitForPaging(*cache);
    const image::ImageF frame = renderer.render(scene, &refined, streamed);
    EXPECT_EQ(refined.bricksStandIn, 0);
    const int64_t inside =
        (box.hi[0] - box.lo[0]) / 16 * ((box.hi[1] - box.lo[1]) / 16) * ((box.hi[2] - box.lo[2]) / 16);
    int64_t coarse = 0;  // every brick above level 0: the most ancestors a stand-in may read
    for (int m = 1; m < s->levelCount(); ++m) coarse += s->level(m).bricksTotal();
    ASSERT_LT(inside + coarse, s->level(0).bricksTotal());
    EXPECT_LE(first.bricksPagedIn + refined.bricksPagedIn, inside + coarse) << "its own bricks and their ancestors";
    FrameOptions options;
    options.part = box;
    expectClose(frame, renderer.render(scene, &exact, options), 0.0, "standins-refined-vs-exact");
    parts.push_back(frame);
  }
  const image::ImageF whole = test::renderStore(s, scene);
  expectJoinedIsWhole(parts, partsFrontToBack(partition, partView(s->meta(), scene)), whole, *s, scene,
                      "standins-3parts");
}

TEST(Parts, TheEnginePassesThePartThrough) {
  ScratchDir dir;
  test::prep("synthetic:sparse,n=64", dir / "s", 16);
  const auto dataset = openDataset("s", dir / "s", size_t(64) << 20);
  const auto& grid = static_cast<const BrickStoreDataset&>(*dataset);
  RenderEngine engine({Backend::Auto, size_t(256) << 20, AtlasFormat::Float});
  const Scene scene = sceneFor(Technique::RayCast, "sparse");
  const image::ImageF whole = engine.render(dataset, scene);
  const Partition partition = partitionBricks(*grid.store(), 4);
  std::vector<image::ImageF> parts;
  for (const PartBox& box : partition.boxes) {
    FrameOptions options;
    options.part = box;
    FrameStats stats;
    parts.push_back(engine.render(dataset, scene, &stats, options));
    EXPECT_LT(stats.bricksDrawn, int64_t(grid.store()->level(0).bricksTotal()));
  }
  expectJoinedIsWhole(parts, partsFrontToBack(partition, grid, scene), whole, *grid.store(), scene, "engine-4parts");
}

TEST(Parts, BadBoxesAndMeshesAreRefused) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=32", dir / "b", 16);
  Scene scene = sceneFor(Technique::RayCast, "mri");
  FrameOptions options;
  options.part = PartBox{{0, 0, 0}, {16, 16, 40}};
  EXPECT_THROW(test::renderStore(s, scene, nullptr, size_t(256) << 20, size_t(256) << 20, options), RenderInputError);
  options.part = PartBox{{16, 0, 0}, {16, 32, 32}};
  EXPECT_THROW(test::renderStore(s, scene, nullptr, size_t(256) << 20, size_t(256) << 20, options), RenderInputError);

  mesh::TetMesh m = mesh::test::kuhnGrid(2, 2, 2);
  mesh::Topology t = mesh::test::matchFaces(m);
  TetRenderer renderer(test::context(), std::make_shared<const TetMeshData>(std::move(m), std::move(t)),
                       size_t(256) << 20);
  options.part = PartBox{{0, 0, 0}, {1, 1, 1}};
  try {
    renderer.render(scene, nullptr, options);
    FAIL() << "a mesh drew a part";
  } catch (const RenderInputError& e) {
    EXPECT_NE(std::string(e.what()).find("mesh"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace voxbrick::render
