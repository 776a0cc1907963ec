// Frames finished on the GPU as 8 bits (Compositor::finish8, FrameRenderer::render8, RenderEngine::render8): the
// bytes must be exactly image::toImage8 of the float frame the same renderer draws, for every pass and kernel, any
// background and size, and the engine's 8-bit frames (what the server sends) those of its float frames (an
// interactive frame's within a level: scaled up as bytes).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <set>
#include <string>

#include "image/Image.h"
#include "render/core/RenderErrors.h"
#include "render/engine/Datasets.h"
#include "render/engine/RenderEngine.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/volume/VolumeRenderer.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::prep;
using test::ScratchDir;

/// Channels of `a` and `b` that differ (every channel when the sizes differ).
size_t bytesThatDiffer(const image::Image8& a, const image::Image8& b) {
  if (a.width != b.width || a.height != b.height || a.rgba.size() != b.rgba.size())
    return std::max(a.rgba.size(), b.rgba.size());
  size_t n = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) n += a.rgba[i] != b.rgba[i];
  return n;
}

/// Pixels neither black nor the background: the frame shows the volume.
size_t pixelsDrawn(const image::Image8& image, const glm::dvec3& background) {
  size_t n = 0;
  for (size_t i = 0; i < image.rgba.size(); i += 4) {
    int far = 0;
    for (int c = 0; c < 3; ++c)
      far = std::max(far, std::abs(int(image.rgba[i + c]) - int(std::lround(background[c] * 255))));
    n += far > 8;
  }
  return n;
}

struct Frame8Case {
  std::string name;
  Scene scene;
};

std::vector<Frame8Case> frameCases() {
  Scene base = test::slicingScene("hot");
  base.lod = 0;
  base.width = 37;  // neither side a multiple of the finish's 8 x 8 workgroups
  base.height = 23;
  base.background = {0.2, 0.35, 0.9};
  std::vector<Frame8Case> cases;
  Scene s = base;
  cases.push_back({"slicing", s});
  s.slab = 16;
  s.ert = 0.99;
  cases.push_back({"slabs", s});
  s = base;
  s.raycast = true;
  s.raycaster = RayCaster::Fragment;
  cases.push_back({"ray caster, fragment", s});
  s.raycaster = RayCaster::Compute;
  s.subBlock = 4;
  cases.push_back({"ray caster, compute", s});
  s.background = {0, 0, 0};
  s.width = s.height = 64;
  cases.push_back({"ray caster, black background", s});
  s.background = {1, 1, 1};
  s.camera.azimuth = 200;
  s.camera.elevation = -35;
  cases.push_back({"ray caster, white background, from below", s});
  s.transparent = true;
  cases.push_back({"no background (straight colour and alpha)", s});
  return cases;
}

TEST(Frame8, IsTheFloatFrameRoundedForEveryPassAndBackground) {
  ScratchDir dir;
  const auto store = prep("synthetic:blobs,n=48", dir / "b", 16);
  auto cache = std::make_shared<store::BrickCache>(store, size_t(256) << 20, 1);
  VolumeRenderer renderer(test::context(), cache, size_t(256) << 20);
  for (const Frame8Case& c : frameCases()) {
    FrameStats floatStats, stats8;
    const image::ImageF floats = renderer.render(c.scene, &floatStats);
    const image::Image8 expected = image::toImage8(floats);
    const image::Image8 bytes = renderer.render8(c.scene, &stats8);
    ASSERT_EQ(bytes.width, c.scene.width) << c.name;
    ASSERT_EQ(bytes.height, c.scene.height) << c.name;
    EXPECT_EQ(bytesThatDiffer(bytes, expected), 0u) << c.name << ": the GPU's 8 bits are not toImage8's";
    EXPECT_GT(pixelsDrawn(bytes, c.scene.background), size_t(c.scene.width * c.scene.height / 8))
        << c.name << ": too little drawn to prove anything";
    EXPECT_EQ(stats8.samples, floatStats.samples) << c.name << ": the same drawing";
    EXPECT_EQ(stats8.bricksDrawn, floatStats.bricksDrawn) << c.name;
    EXPECT_GT(stats8.msReadback, 0.0) << c.name;
    if (c.scene.raycast) {
      EXPECT_EQ(stats8.raycaster, floatStats.raycaster) << c.name;
    }
  }
  // A flip of the rows (the finish writes them top first) or a swap of channels would differ above: the views are
  // not symmetric top to bottom, and the background is not grey.
}

// A sequence (orbit's turntable) plans each next frame while the GPU draws the last: every frame must be the one
// render8 draws alone, delivered in order, whatever moved between them (the view, the level cut, the kernel); a
// frame that cannot be planned fails as its own frame, after the frames before it were delivered.
TEST(Frame8, ASequencePlannedAheadDrawsEachFrameAsAlone) {
  ScratchDir dir;
  const auto store = prep("synthetic:blobs,n=64", dir / "b", 16);
  std::vector<Scene> scenes;
  Scene s = test::slicingScene("hot");
  s.raycast = true;
  s.width = 40;
  s.height = 32;
  s.lod = 2;
  for (int i = 0; i < 6; ++i) {
    s.camera.azimuth = 60.0 * i;
    s.camera.distance = 4.0 - 0.45 * i;  // closer and closer: the level cut moves
    s.raycaster = i % 2 ? RayCaster::Compute : RayCaster::Fragment;
    scenes.push_back(s);
  }
  auto cache = std::make_shared<store::BrickCache>(store, size_t(256) << 20, 1);
  VolumeRenderer alone(test::context(), cache, size_t(256) << 20), ahead(test::context(), cache, size_t(256) << 20);
  std::vector<size_t> order;
  std::set<int64_t> cuts;
  ahead.renderSequence8(scenes, {}, [&](size_t i, image::Image8&& image, const FrameStats& stats) {
    order.push_back(i);
    FrameStats own;
    const image::Image8 expected = alone.render8(scenes[i], &own);
    EXPECT_EQ(bytesThatDiffer(image, expected), 0u) << "frame " << i;
    EXPECT_GT(pixelsDrawn(image, scenes[i].background), 40u) << "frame " << i;
    EXPECT_EQ(stats.samples, own.samples) << "frame " << i;
    EXPECT_EQ(stats.bricksDrawn, own.bricksDrawn) << "frame " << i;
    EXPECT_GT(stats.msTotal, 0.0);
    EXPECT_EQ(stats.plannedAhead, i > 0) << "planned while the frame before was drawn: frame " << i;
    EXPECT_FALSE(own.plannedAhead);
    cuts.insert(stats.bricksDrawn);
  });
  EXPECT_EQ(order, (std::vector<size_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_GE(cuts.size(), 3u) << "the level cut never moved: the test no longer tests it";

  std::vector<Scene> failing = {scenes[0], scenes[1], scenes[2]};
  failing[2].subBlock = 3;  // cuts no brick of 16: refused when planned
  order.clear();
  EXPECT_THROW(ahead.renderSequence8(failing, {}, [&](size_t i, image::Image8&&, const FrameStats&) { order.push_back(i); }),
               RenderInputError);
  EXPECT_EQ(order, (std::vector<size_t>{0, 1})) << "the frames before the one that failed";
  // And the renderer draws on as before.
  EXPECT_EQ(bytesThatDiffer(ahead.render8(scenes[3]), alone.render8(scenes[3])), 0u);
}

TEST(Frame8, TheEnginesBytesAreItsFloatFramesRoundedForGridsMeshesAndInteractiveFrames) {
  ScratchDir dir;
  prep("synthetic:blobs,n=40", dir / "g", 8);
  const test::CommandResult mesh = test::runVoxbrick("prep synthetic-mesh:ball,n=6 -q -o " + (dir / "m").string());
  ASSERT_EQ(mesh.exitCode, 0) << mesh.output;
  RenderEngine engine(RenderEngineOptions{});
  for (const char* name : {"g", "m", "m projected"}) {
    const std::string path(name, 1);
    const auto dataset = openDataset(path, dir / path, size_t(64) << 20);
    Scene scene = test::slicingScene("hot");
    scene.raycast = true;
    if (std::string(name) == "m projected") scene.visibility = TetSort::Mpvo;
    scene.width = 40;
    scene.height = 30;
    scene.background = {0.1, 0.1, 0.1};
    engine.render(dataset, scene);  // paged in: the frames below are drawn alike
    const image::Image8 bytes = engine.render8(dataset, scene);
    EXPECT_EQ(bytesThatDiffer(bytes, image::toImage8(engine.render(dataset, scene))), 0u) << name;
    EXPECT_GT(pixelsDrawn(bytes, scene.background), 40u) << name;
  }
  // An interactive frame's bytes are drawn as bytes at its smaller size and scaled up as bytes: within a level of
  // the float frame scaled up and rounded.
  const auto grid = openDataset("g", dir / "g", size_t(64) << 20);
  Scene scene = test::slicingScene("hot");
  scene.raycast = true;
  scene.interactive = true;
  scene.timeBudgetMs = 10;  // at one sample a ms: the smallest drawing the ladder has
  FrameStats stats;
  FrameOptions options;
  options.rateSamplesPerMs = 1;
  const image::Image8 bytes = engine.render8(grid, scene, &stats, options);
  ASSERT_TRUE(stats.interactive.is_object());
  EXPECT_LT(stats.interactive.value("width", scene.width), scene.width) << "drawn smaller";
  EXPECT_EQ(bytes.width, scene.width);
  const image::Image8 rounded = image::toImage8(engine.render(grid, scene, nullptr, options));
  ASSERT_EQ(bytes.rgba.size(), rounded.rgba.size());
  int most = 0;
  for (size_t i = 0; i < bytes.rgba.size(); ++i) most = std::max(most, std::abs(bytes.rgba[i] - rounded.rgba[i]));
  EXPECT_LE(most, 1);
  // And exactly the bytes of its drawing scaled by image::scaleImage.
  Scene drawn = scene;
  drawn.interactive = false;
  drawn.width = stats.interactive["width"].get<int>(), drawn.height = stats.interactive["height"].get<int>();
  drawn.step = stats.interactive["step"].get<double>(), drawn.lod = stats.interactive["lod"].get<double>();
  EXPECT_EQ(bytesThatDiffer(bytes, image::scaleImage(engine.render8(grid, drawn), scene.width, scene.height)), 0u);
}

}  // namespace
}  // namespace voxbrick::render
