// `voxbrick serve --replay-frames DIR`: the real server answering with frames drawn beforehand, each the one nearest the
// request's camera (what the benchmarks measure everything but drawing with), and a bad replay directory refused at
// start, naming what is wrong.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "image/Image.h"
#include "server/ServerProcess.h"

namespace voxbrick::test {
namespace {

class ServeReplayTest : public SparseDatasetSuite {};

void solidPng(const std::filesystem::path& file, uint8_t red) {
  image::Image8 image{48, 48, {}};
  for (int i = 0; i < 48 * 48; ++i) image.rgba.insert(image.rgba.end(), {red, 7, 9, 255});
  image::writePng(file, image);
}

TEST_F(ServeReplayTest, EachFrameIsTheStoredFrameNearestItsCamera) {
  const auto replay = scratch() / "replay";
  std::filesystem::create_directories(replay);
  solidPng(replay / "front.png", 10);
  solidPng(replay / "back.png", 200);
  writeFile(replay / "replay.json", R"({"frames": [{"file": "front.png", "azimuth": 0, "elevation": 20},
                                                   {"file": "back.png", "azimuth": 180, "elevation": 20}]})");
  auto server = serve("--replay-frames " + replay.string() + " --replay-draw-ms 5");
  EXPECT_NE(server->log().find("replay of 2 frames"), std::string::npos) << server->log();
  for (const auto& [orbit, red] : std::vector<std::pair<std::string, int>>{{"170,25", 200}, {"-20,10", 10}}) {
    const auto out = scratch() / ("replayed-" + std::to_string(red) + ".png");
    const auto r = runVoxbrick("request 127.0.0.1:" + std::to_string(server->port()) +
                               " --dataset sparse --size 48x48 --orbit " + orbit + " -o " + out.string() + " --stats " +
                               out.string() + ".json");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const image::Image8 frame = image::readPng(out);
    ASSERT_EQ(frame.width, 48);
    EXPECT_EQ(frame.rgba.at(0), red) << "orbit " << orbit;
    EXPECT_EQ(frame.rgba.at(1), 7);
    const auto stats = nlohmann::json::parse(readFile(out.string() + ".json"));
    EXPECT_GE(stats["ms"].value("total", 0.0), 5.0) << stats.dump();
  }
  EXPECT_EQ(server->stop(SIGTERM), 0);
}

TEST_F(ServeReplayTest, ABadReplayDirectoryIsRefusedAtStart) {
  const auto empty = scratch() / "no-replay";
  std::filesystem::create_directories(empty);
  auto r = runVoxbrick("serve --no-config --port 0 --datasets " + datasets() + " --replay-frames " + empty.string());
  EXPECT_NE(r.exitCode, 0);
  EXPECT_NE(r.output.find("replay.json: cannot be read"), std::string::npos) << r.output;
  r = runVoxbrick("serve --no-config --port 0 --datasets " + datasets() + " --replay-draw-ms 5");
  EXPECT_NE(r.exitCode, 0);
  EXPECT_NE(r.output.find("--replay-draw-ms requires --replay-frames"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace voxbrick::test
