// The replay frame source (`serve --replay-frames`): the stored frame nearest the scene's camera and of its size, the
// drawing time it is given (and gives up when cancelled), and a damaged replay directory refused naming what is wrong.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

#include <nlohmann/json.hpp>

#include "image/Image.h"
#include "render/core/Dataset.h"
#include "render/core/RenderErrors.h"
#include "render/engine/ReplayFrameSource.h"
#include "support/StubDataset.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::ScratchDir;

/// A PNG of `width` x `height` filled with `value` (red), in `dir`/`name`.
void solidPng(const std::filesystem::path& file, int width, int height, uint8_t value) {
  image::Image8 image{width, height, {}};
  for (int i = 0; i < width * height; ++i) image.rgba.insert(image.rgba.end(), {value, 0, 0, 255});
  std::filesystem::create_directories(file.parent_path());
  image::writePng(file, image);
}

struct Entry {
  std::string file;
  double azimuth, elevation;
  int width, height;
  uint8_t value;
};

/// A replay directory of solid frames, each of its own red value.
void replayDir(const std::filesystem::path& dir, const std::vector<Entry>& entries) {
  nlohmann::json frames = nlohmann::json::array();
  for (const Entry& e : entries) {
    solidPng(dir / e.file, e.width, e.height, e.value);
    frames.push_back({{"file", e.file}, {"azimuth", e.azimuth}, {"elevation", e.elevation}});
  }
  test::writeFile(dir / "replay.json", nlohmann::json{{"frames", frames}}.dump());
}

Scene orbitScene(double azimuth, double elevation, int width, int height) {
  Scene scene;
  scene.camera.orbit = true;
  scene.camera.azimuth = azimuth;
  scene.camera.elevation = elevation;
  scene.width = width;
  scene.height = height;
  return scene;
}

class ReplayFramesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    replayDir(mDir.path(), {{"64/a000.png", 0, 20, 64, 64, 10},
                            {"64/a090.png", 90, 20, 64, 64, 20},
                            {"64/a180.png", 180, 20, 64, 64, 30},
                            {"64/top.png", 0, 89, 64, 64, 40},
                            {"32/a000.png", 0, 20, 32, 16, 50},
                            {"32/a180.png", 180, 20, 32, 16, 60}});
    mFrames = std::make_shared<const ReplayFrames>(mDir.path());
  }
  uint8_t red(const image::Image8& image) const { return image.rgba.at(0); }

  ScratchDir mDir;
  std::shared_ptr<const ReplayFrames> mFrames;
  std::shared_ptr<const Dataset> mDataset = std::make_shared<test::StubDataset>("any", "any");
};

TEST_F(ReplayFramesTest, TheFrameNearestTheCameraOfTheScenesSizeIsReplayed) {
  ReplayFrameSource source(mFrames, std::chrono::microseconds(0));
  EXPECT_EQ(red(source.render8(mDataset, orbitScene(80, 20, 64, 64))), 20);
  EXPECT_EQ(red(source.render8(mDataset, orbitScene(-175, 10, 64, 64))), 30);  // 185°: nearest 180
  EXPECT_EQ(red(source.render8(mDataset, orbitScene(120, 85, 64, 64))), 40);   // near the pole: the top view
  // Of the requested size: the 32 x 16 frames, though a 64 x 64 one is as near.
  const image::Image8 small = source.render8(mDataset, orbitScene(170, 20, 32, 16));
  EXPECT_EQ(small.width, 32);
  EXPECT_EQ(small.height, 16);
  EXPECT_EQ(red(small), 60);
  // An eye, centre and up: the direction from the centre to the eye (the orbit's azimuth 90 at elevation 20 about
  // +z is -x: front +y, side -x).
  Scene eye = orbitScene(0, 0, 64, 64);
  eye.camera.orbit = false;
  eye.camera.center = {5, 5, 5};
  eye.camera.eye = glm::dvec3(5, 5, 5) + 3.0 * glm::dvec3(-std::cos(glm::radians(20.0)), 0, std::sin(glm::radians(20.0)));
  EXPECT_EQ(red(source.render8(mDataset, eye)), 20);
}

TEST_F(ReplayFramesTest, AnotherSizeIsTheNearestFrameScaled) {
  ReplayFrameSource source(mFrames, std::chrono::microseconds(0));
  const image::Image8 image = source.render8(mDataset, orbitScene(95, 20, 48, 24));
  ASSERT_EQ(image.width, 48);
  ASSERT_EQ(image.height, 24);
  for (size_t i = 0; i < image.rgba.size(); i += 4) ASSERT_EQ(image.rgba[i], 20) << "pixel " << i / 4;
  // render() gives the same pixels as floats.
  const image::ImageF f = source.render(mDataset, orbitScene(95, 20, 48, 24));
  EXPECT_FLOAT_EQ(f.rgba.at(0), 20.0f / 255.0f);
}

TEST_F(ReplayFramesTest, EachFrameTakesItsDrawingTimeUnlessGivenUp) {
  ReplayFrameSource source(mFrames, std::chrono::milliseconds(40));
  Scene scene = orbitScene(0, 20, 64, 64);
  scene.interactive = true;
  scene.timeBudgetMs = 50;
  FrameStats stats;
  const auto start = std::chrono::steady_clock::now();
  source.render8(mDataset, scene, &stats);
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(40));
  EXPECT_GE(stats.msTotal, 40.0);
  EXPECT_EQ(stats.samplesEstimated, 64.0 * 64.0);
  ASSERT_TRUE(stats.interactive.is_object());
  EXPECT_EQ(stats.interactive.value("rung", -1), 0);
  EXPECT_EQ(stats.interactive.value("budget_ms", 0.0), 50.0);
  EXPECT_GE(stats.interactive.value("actual_ms", 0.0), 40.0);

  FrameOptions cancelled;
  cancelled.cancelled = [] { return true; };
  EXPECT_THROW(source.render8(mDataset, scene, nullptr, cancelled), FrameCancelled);
  FrameOptions limited;
  limited.maxSamples = 100;
  EXPECT_THROW(source.render8(mDataset, scene, nullptr, limited), RenderLimitError);
  EXPECT_THROW(source.render8(nullptr, scene), RenderInputError);
  EXPECT_NE(source.describe().find("replay of 6 frames"), std::string::npos) << source.describe();
}

/// The message a replay directory written by `write` is refused with.
template <class Write>
std::string refusal(Write write) {
  ScratchDir dir;
  write(dir.path());
  try {
    ReplayFrames frames(dir.path());
  } catch (const RenderInputError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(ReplayFramesRefused, ADamagedDirectoryIsRefusedNamingWhatIsWrong) {
  EXPECT_NE(refusal([](const auto&) {}).find("replay.json: cannot be read"), std::string::npos);
  EXPECT_NE(refusal([](const auto& d) { test::writeFile(d / "replay.json", "{\"frames\": ["); }).find("not JSON"),
            std::string::npos);
  EXPECT_NE(refusal([](const auto& d) { test::writeFile(d / "replay.json", R"({"frames": []})"); })
                .find("'frames' must be a list of at least one frame"),
            std::string::npos);
  const std::string gone = refusal([](const auto& d) {
    test::writeFile(d / "replay.json", R"({"frames": [{"file": "gone.png", "azimuth": 0, "elevation": 0}]})");
  });
  EXPECT_NE(gone.find("gone.png does not exist"), std::string::npos) << gone;
  const std::string notPng = refusal([](const auto& d) {
    test::writeFile(d / "f.png", "not a png at all, just some text");
    test::writeFile(d / "replay.json", R"({"frames": [{"file": "f.png", "azimuth": 0, "elevation": 0}]})");
  });
  EXPECT_NE(notPng.find("frame 0: "), std::string::npos) << notPng;
  EXPECT_NE(notPng.find("f.png: not a readable PNG"), std::string::npos) << notPng;
  const std::string noAzimuth = refusal([](const auto& d) {
    solidPng(d / "f.png", 4, 4, 1);
    test::writeFile(d / "replay.json", R"({"frames": [{"file": "f.png", "azimuth": "east", "elevation": 0}]})");
  });
  EXPECT_NE(noAzimuth.find("frame 0: 'azimuth' must be a finite number of degrees"), std::string::npos) << noAzimuth;
  const std::string noFile = refusal([](const auto& d) {
    test::writeFile(d / "replay.json", R"({"frames": [{"azimuth": 0, "elevation": 0}]})");
  });
  EXPECT_NE(noFile.find("frame 0: 'file' must name a PNG"), std::string::npos) << noFile;
}

}  // namespace
}  // namespace voxbrick::render
