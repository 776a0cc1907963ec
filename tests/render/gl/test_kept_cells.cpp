// The ray caster's cell table kept between frames (render/gl/volume/KeptCells.h): a renderer that keeps it must draw,
// frame after frame, exactly the image a renderer filling the table anew draws (the path it replaced), whatever
// changed in between (the view, the level cut, the transfer function, the sub-block size, stand-ins, a part's frame,
// a frame given up part way), and must do no more than the change asks: nothing sent for a frame of the same bricks,
// only the changed bricks' cells for a new level cut.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "image/Image.h"
#include "render/core/RenderErrors.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/volume/VolumeRenderer.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::prep;
using test::ScratchDir;

/// A renderer that keeps its table, and the reference: every frame drawn by a renderer filling it anew.
class KeptAndFilled {
 public:
  /// `paged`: the table paged on the GPU (FrameOptions::pagedCellTable), else one grid of cells.
  explicit KeptAndFilled(std::shared_ptr<const store::BrickStore> s, bool paged, size_t gpuBudget = size_t(256) << 20)
      : mPaged(paged),
        mStore(std::move(s)),
        mCache(std::make_shared<store::BrickCache>(mStore, size_t(256) << 20, 1)),
        mKept(test::context(), mCache, gpuBudget),
        mFilled(test::context(), mCache, gpuBudget) {}

  /// The kept renderer's frame of `scene`, which must equal the filled one's bit for bit, as must its cell table
  /// (both renderers page the same bricks in the same order into atlases too large to evict: the same slots); its
  /// statistics.
  FrameStats frame(const Scene& scene, const std::string& what, FrameOptions options = {}) {
    FrameStats kept, filled;
    options.pagedCellTable = mPaged;
    options.keepCellTable = true;
    const image::ImageF a = mKept.render(scene, &kept, options);
    const std::vector<glm::i16vec4> keptTable = mKept.cellTable().readBack();
    options.keepCellTable = false;
    const image::ImageF b = mFilled.render(scene, &filled, options);
    const std::vector<glm::i16vec4> filledTable = mFilled.cellTable().readBack();
    EXPECT_EQ(keptTable.size(), filledTable.size()) << what;
    size_t differ = 0;
    for (size_t i = 0; i < std::min(keptTable.size(), filledTable.size()); ++i) differ += keptTable[i] != filledTable[i];
    EXPECT_EQ(differ, 0u) << what << ": cells of the kept table that a table filled anew does not hold";
    EXPECT_GT(test::meanBrightness(b), 0.002) << what;
    EXPECT_EQ(image::compareImages(a, b).maxAbs, 0.0) << what << ": the kept table draws another image";
    EXPECT_EQ(kept.samples, filled.samples) << what;
    EXPECT_EQ(kept.bricksDrawn, filled.bricksDrawn) << what;
    EXPECT_EQ(kept.boxesDrawn, filled.boxesDrawn) << what;
    EXPECT_EQ(kept.subBlocksSkipped, filled.subBlocksSkipped) << what;
    EXPECT_EQ(filled.cellBricksChanged, -1) << what << ": the filled path has no kept table";
    return kept;
  }

  VolumeRenderer& kept() { return mKept; }
  /// Options of the kept renderer's frames drawn outside frame().
  FrameOptions options() const {
    FrameOptions o;
    o.pagedCellTable = mPaged;
    return o;
  }
  /// What sending a whole table of `pages` pages at cell size `cell` sends: the pages' cells and the directory, or
  /// one grid's every cell.
  int64_t pagesSent(int64_t pages, int cell) const {
    const store::Vec3i& d = mStore->meta().dims;
    auto blocks = [&](int64_t n) { return ((n + cell - 1) / cell + CellTable::kLeapBlock - 1) / CellTable::kLeapBlock; };
    if (!mPaged) return ((d.x + cell - 1) / cell) * ((d.y + cell - 1) / cell) * ((d.z + cell - 1) / cell);
    return pages * CellTable::kPageCells + blocks(d.x) * blocks(d.y) * blocks(d.z);
  }

 private:
  bool mPaged;
  std::shared_ptr<const store::BrickStore> mStore;
  std::shared_ptr<store::BrickCache> mCache;
  VolumeRenderer mKept, mFilled;
};

class KeptCells : public ::testing::TestWithParam<bool> {};

Scene blobsScene() {
  Scene scene = test::slicingScene("hot");
  scene.raycast = true;
  scene.subBlock = 4;
  scene.lod = 0;
  return scene;
}

TEST_P(KeptCells, AFrameOfTheSameBricksSendsNothing) {
  ScratchDir dir;
  KeptAndFilled r(prep("synthetic:blobs,n=64", dir / "b", 16), GetParam());
  Scene scene = blobsScene();
  const FrameStats first = r.frame(scene, "first");
  EXPECT_EQ(first.cellBricksChanged, first.bricksDrawn) << "the first frame marks every brick";
  EXPECT_EQ(first.cellsSent, r.pagesSent(r.kept().cellTable().pages(), 4))
      << "and sends the whole table: every page and the directory";
  const FrameStats again = r.frame(scene, "again");
  EXPECT_EQ(again.cellBricksChanged, 0);
  EXPECT_EQ(again.cellsSent, 0);
  EXPECT_EQ(again.bricksPagedIn, 0);
  // Another view of the same bricks (level 0 everywhere, nothing culled): the order changes, the set does not.
  for (double azimuth : {75.0, 160.0, 250.0}) {
    scene.camera.azimuth = azimuth;
    const FrameStats turned = r.frame(scene, "azimuth " + std::to_string(azimuth));
    EXPECT_EQ(turned.bricksDrawn, first.bricksDrawn);
    EXPECT_EQ(turned.cellBricksChanged, 0) << azimuth;
    EXPECT_EQ(turned.cellsSent, 0) << azimuth;
  }
}

TEST_P(KeptCells, ANewLevelCutChangesOnlyItsBricks) {
  ScratchDir dir;
  KeptAndFilled r(prep("synthetic:blobs,n=96", dir / "b", 16), GetParam());
  Scene scene = blobsScene();
  scene.lod = 2;
  scene.width = scene.height = 48;
  int partial = 0;
  // Closer and closer: the cut moves to finer levels near the eye.
  for (double distance : {4.0, 3.0, 2.2, 1.8, 1.5, 1.8, 4.0}) {
    scene.camera.distance = distance;
    const std::string what = "distance " + std::to_string(distance);
    const FrameStats s = r.frame(scene, what);
    EXPECT_LE(s.cellBricksChanged, s.bricksDrawn + 0) << what;
    EXPECT_LE(s.cellsSent, r.pagesSent(r.kept().cellTable().pages(), 4)) << what;
    if (s.cellBricksChanged > 0 && s.cellBricksChanged < s.bricksDrawn) {
      ++partial;
      // Pages: only the changed blocks' (one grid sends every cell once a quarter of its blocks changed, as here).
      if (GetParam()) {
        EXPECT_LT(s.cellsSent, r.pagesSent(r.kept().cellTable().pages(), 4)) << what;
      }
    }
  }
  EXPECT_GE(partial, 2) << "the level cut never changed in part: the test no longer tests it";
}

TEST_P(KeptCells, TheTableGrowsAsMoreIsDrawn) {
  ScratchDir dir;
  KeptAndFilled r(prep("synthetic:blobs,n=192", dir / "b", 16), GetParam());
  Scene scene = blobsScene();
  scene.width = scene.height = 40;
  // From inside, most bricks culled and few pages; then the whole volume, many more pages than the first frame's
  // table had room for (its buffer grows, and must hold the pages it had too).
  scene.camera.distance = 0.3;
  r.frame(scene, "inside");
  const int64_t few = r.kept().cellTable().pages();
  scene.camera.distance = 2.5;
  const FrameStats all = r.frame(scene, "outside");
  const int64_t many = r.kept().cellTable().pages();
  EXPECT_GT(many, 2 * few + 64) << "the table did not grow past its first buffer: the test no longer tests it";
  EXPECT_GT(all.cellBricksChanged, 0);
  scene.camera.distance = 0.3;
  r.frame(scene, "inside again");
}

TEST_P(KeptCells, ClassificationAndSubBlocksBuildItAnew) {
  ScratchDir dir;
  KeptAndFilled r(prep("synthetic:blobs,n=64", dir / "b", 16), GetParam());
  Scene scene = blobsScene();
  r.frame(scene, "first");
  scene.window = std::array<double, 2>{0.2, 1.0};  // other sub-blocks empty
  const FrameStats windowed = r.frame(scene, "window");
  EXPECT_EQ(windowed.cellBricksChanged, windowed.bricksDrawn);
  scene.subBlock = 8;
  const FrameStats coarser = r.frame(scene, "sub-block 8");
  EXPECT_EQ(coarser.cellBricksChanged, coarser.bricksDrawn);
  EXPECT_EQ(coarser.cellsSent, r.pagesSent(r.kept().cellTable().pages(), 8));
  scene.transferFunction = TransferFunction::load("grayscale");
  const FrameStats tf = r.frame(scene, "grayscale");
  EXPECT_EQ(tf.cellBricksChanged, tf.bricksDrawn);
  // Colour alone classifies alike: the table stands.
  TransferFunction recoloured = scene.transferFunction;
  std::vector<TransferFunction::Point> points = recoloured.points();
  for (TransferFunction::Point& p : points) p.rgba = glm::dvec4(1.0 - p.rgba.r, p.rgba.g, p.rgba.b, p.rgba.a);
  scene.transferFunction = TransferFunction(points, recoloured.referenceLength());
  const FrameStats colour = r.frame(scene, "recoloured");
  EXPECT_EQ(colour.cellBricksChanged, 0);
}

TEST_P(KeptCells, FramesOfBatchesPartsAndGivenUpFramesBetweenLeaveItRight) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=64", dir / "b", 16);
  KeptAndFilled r(s, GetParam());
  Scene scene = blobsScene();
  const FrameStats first = r.frame(scene, "first");
  // A part's frame (sort-last) fills its batches' tables: the next whole frame builds the kept table anew.
  FrameOptions part = r.options();
  part.part = PartBox{{0, 0, 0}, {32, 64, 64}};
  r.kept().render(scene, nullptr, part);
  const FrameStats after = r.frame(scene, "after a part");
  EXPECT_EQ(after.cellBricksChanged, first.bricksDrawn);
  // A frame given up at each of its first checkpoints, while the bricks change (another level cut) or not.
  for (int giveUpAt : {1, 2, 3, 8, 30}) {
    for (double lod : {2.0, 0.0}) {
      Scene other = scene;
      other.lod = lod;
      other.camera.distance = 1.6;
      FrameOptions cancelled = r.options();
      int asked = 0;
      cancelled.cancelled = [&] { return ++asked >= giveUpAt; };
      try {
        r.kept().render(other, nullptr, cancelled);
      } catch (const FrameCancelled&) {
      }
      r.frame(scene, "after giving up at checkpoint " + std::to_string(giveUpAt) + ", lod " + std::to_string(lod));
    }
  }
}

TEST_P(KeptCells, StandInsAreReplacedAsTheirBricksArrive) {
  ScratchDir dir;
  const auto s = prep("synthetic:blobs,n=64", dir / "b", 16);
  auto cache = std::make_shared<store::BrickCache>(s, size_t(256) << 20, 1);
  VolumeRenderer kept(test::context(), cache, size_t(256) << 20);
  Scene scene = blobsScene();
  FrameOptions streaming;
  streaming.pagedCellTable = GetParam();
  streaming.standIns = true;
  FrameStats stats;
  const image::ImageF cold = kept.render(scene, &stats, streaming);
  ASSERT_GT(stats.bricksStandIn, 0) << "a cold frame draws stand-ins";
  int frames = 0;
  while (stats.bricksStandIn > 0 && frames++ < 20) {
    test::waitForPaging(*cache);
    kept.render(scene, &stats, streaming);
    EXPECT_GT(stats.cellBricksChanged, 0) << "bricks replaced their stand-ins";
  }
  ASSERT_EQ(stats.bricksStandIn, 0);
  const image::ImageF exact = kept.render(scene, &stats, streaming);
  EXPECT_EQ(stats.cellBricksChanged, 0);
  // The same renderer filling its table anew (the same slots: another atlas would round sample coordinates
  // differently).
  streaming.keepCellTable = false;
  EXPECT_EQ(image::compareImages(exact, kept.render(scene, nullptr, streaming)).maxAbs, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Tables, KeptCells, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& p) { return p.param ? "Paged" : "OneGrid"; });

}  // namespace
}  // namespace voxbrick::render
