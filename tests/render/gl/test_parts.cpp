// Sort-last rendering's renderer side: the parts of a partition, each drawn alone with FrameOptions::part (only the
// samples owned inside its box, premultiplied, no background), joined with the serial compositor in the partition's
// front-to-back order and finished over the background, give the whole frame within 1/255, for N = 1..5 parts, with
// the ray caster, slicing and slabs, on several fields and cameras and with level of detail; a part pages only its
// own bricks; a part on a mesh is refused.
#include <gtest/gtest.h>

#include <string>

#include "image/Image.h"
#include "mesh/MeshStoreFixtures.h"
#include "render/core/RenderErrors.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/tets/TetRenderer.h"
#include "render/volume/Partition.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::expectClose;
using test::meanBrightness;
using test::prep;
using test::ScratchDir;

enum class Technique { RayCast, Slicing, Slabs };

/// A small frame of `tf` with `technique`: the ray caster (the default), slicing of whole bricks (whose whole frame
/// shares rasterised faces where a part's owns exactly) or texture slabs.
Scene sceneFor(Technique technique, const std::string& tf) {
  Scene scene;
  scene.width = 72;
  scene.height = 64;
  scene.camera.azimuth = 35;
  scene.camera.elevation = 25;
  scene.camera.distance = 2.2;
  scene.transferFunction = TransferFunction::load(tf);
  scene.step = 0.5;
  if (technique != Technique::RayCast) scene.raycast = false;
  if (technique == Technique::Slicing) scene.slab = 0, scene.ert = 0, scene.subBlock = 0;
  return scene;
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
    const std::vector<int> order = partsFrontToBack(partition, partView(s->meta(), scene));
    std::vector<image::ImageF> parts;
    int64_t drawn = 0;
    for (int p = 0; p < n; ++p) {
      FrameOptions options;
      options.part = partition.boxes[size_t(p)];
      FrameStats stats;
      parts.push_back(renderer.render(scene, &stats, options));
      drawn += stats.bricksDrawn;
      EXPECT_LE(stats.bricksDrawn, wholeStats.bricksDrawn) << what << ", part " << p << " of " << n;
    }
    EXPECT_GE(drawn, wholeStats.bricksDrawn) << what << ", " << n << " parts: every brick in some part";
    const image::ImageF joined = finishPartial(compositeSerial(parts, order), scene);
    expectClose(joined, whole, 1.0 / 255, what + "-" + std::to_string(n) + "parts");
  }
}

/// The fields and cameras of the comparison: a smooth field with the MRI preset, a sparse field, the camera inside
/// the volume, an orthographic view and a coarse level of detail.
void expectEveryCase(Technique technique) {
  ScratchDir dir;
  const auto blobs = prep("synthetic:blobs,n=64", dir / "b", 16);
  const auto sparse = prep("synthetic:sparse,n=64", dir / "s", 16);
  const Scene mri = sceneFor(technique, "mri");
  expectPartsGiveTheWholeFrame(blobs, mri, "mri");
  expectPartsGiveTheWholeFrame(sparse, sceneFor(technique, "sparse"), "sparse");
  Scene inside = mri;
  inside.camera.distance = 0.25, inside.camera.fovY = 75;
  expectPartsGiveTheWholeFrame(blobs, inside, "inside");
  Scene ortho = mri;
  ortho.camera.orthographic = true;
  ortho.camera.azimuth = 200, ortho.camera.elevation = -40;
  expectPartsGiveTheWholeFrame(blobs, ortho, "ortho");
  Scene lod = mri;
  lod.lod = 4;
  expectPartsGiveTheWholeFrame(blobs, lod, "lod", 1);
}

TEST(Parts, RayCasterPartsCompositeToTheWholeFrame) { expectEveryCase(Technique::RayCast); }
TEST(Parts, SlicingPartsCompositeToTheWholeFrame) { expectEveryCase(Technique::Slicing); }
TEST(Parts, SlabPartsCompositeToTheWholeFrame) { expectEveryCase(Technique::Slabs); }

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
