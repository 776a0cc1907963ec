// An OME-Zarr rendered live gives the frames of the store `voxbrick prep` makes of it, bit for bit: its own pyramid
// levels and an averaged one, slicing and slabs, and through the `render` command.
#include <gtest/gtest.h>

#include <string>

#include "brickstore/read/ZarrStore.h"
#include "image/Image.h"
#include "render/gl/GlFixtures.h"
#include "support/TestSupport.h"
#include "support/ZarrFixtures.h"

namespace voxbrick::render {
namespace {

using test::meanBrightness;
using test::renderStore;
using test::ScratchDir;

constexpr const char* kSpec = R"({"shape": [48, 40, 56], "levels": 4, "chunks": [16, 16, 16], "dtype": "<u2",
    "scale": [1.5, 1.0, 1.0], "compressor": {"id": "blosc", "cname": "lz4", "shuffle": 1}})";

TEST(ZarrFrames, EqualThePreppedStoreBitForBit) {
  ScratchDir dir;
  constexpr int kBrick = 8;
  const auto zarr = test::writeZarr(dir / "v.ome.zarr", nlohmann::json::parse(kSpec));
  const auto prepped = test::prep(zarr.string(), dir / "prepped", kBrick);
  const auto live = store::ZarrStore::open(zarr, {"", kBrick});
  ASSERT_GE(live->openStats().ownLevels, 3);
  bool coarse = false;
  for (const double lod : {0.0, 8.0})
    for (const int slab : {0, 32}) {
      const std::string what = "lod" + std::to_string(int(lod)) + "-slab" + std::to_string(slab);
      Scene scene = test::lodScene(lod);
      scene.camera.distance = 2.0;
      scene.slab = slab;
      scene.raycast = false;
      FrameStats liveStats, preppedStats;
      const image::ImageF a = renderStore(live, scene, &liveStats);
      const image::ImageF b = renderStore(prepped, scene, &preppedStats);
      EXPECT_GT(meanBrightness(b), 0.002) << what << ": a black frame proves nothing";
      ASSERT_EQ(a.rgba.size(), b.rgba.size());
      size_t differ = 0;
      for (size_t i = 0; i < a.rgba.size(); ++i) differ += a.rgba[i] != b.rgba[i];
      EXPECT_EQ(differ, 0u) << what;
      EXPECT_EQ(liveStats.bricksPerLevel, preppedStats.bricksPerLevel) << what;
      coarse = coarse || liveStats.bricksCoarse > 0;
    }
  EXPECT_TRUE(coarse) << "no frame drew a coarse level (the Zarr's own)";
}

TEST(ZarrFrames, RenderCommandTakesTheDirectory) {
  ScratchDir dir;
  const auto zarr = test::writeZarr(dir / "v.ome.zarr", nlohmann::json::parse(kSpec));
  const std::string scene = " --size 96x80 --tf hot -q";
  auto run = [&](const std::string& args) {
    const auto r = test::runVoxbrick(args);
    EXPECT_EQ(r.exitCode, 0) << r.output;
  };
  run("prep " + zarr.string() + " --brick 16 -q -o " + (dir / "prepped").string());
  run("render " + zarr.string() + " --brick 16" + scene + " -o " + (dir / "live.png").string());
  run("render " + (dir / "prepped").string() + scene + " -o " + (dir / "prepped.png").string());
  const image::Image8 live = image::readPng(dir / "live.png"), prepped = image::readPng(dir / "prepped.png");
  ASSERT_EQ(live.rgba.size(), prepped.rgba.size());
  EXPECT_EQ(live.rgba, prepped.rgba);
}

}  // namespace
}  // namespace voxbrick::render
