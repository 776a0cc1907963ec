// The clients' jpeg frames against the real server: `voxbrick request --encoding jpeg` (decoded into a PNG, or the
// JPEG as it came into a .jpg), `voxbrick load --encoding jpeg`, and the Python example client.
#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "cli/CliRun.h"
#include "image/Image.h"
#include "image/ImageFile.h"
#include "server/ServerProcess.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using nlohmann::json;
using test::ServerProcess;

class RequestJpegTest : public test::SparseDatasetSuite {
 protected:
  std::unique_ptr<ServerProcess> start() {
    return serve("--render-threads 1");
  }
  static std::string address(const ServerProcess& server) { return "127.0.0.1:" + std::to_string(server.port()); }
  static std::string scene() {
    const auto path = scratch() / "scene.json";
    test::writeFile(path, std::string(R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [96, 80],
                                          "transfer_function": "sparse", "background": [0.1, 0.2, 0.3]})"));
    return path.string();
  }
};

double psnr(const image::Image8& a, const image::Image8& b) {
  return image::compareImages(image::toImageF(a), image::toImageF(b)).psnr;
}

TEST_F(RequestJpegTest, RequestWritesTheDecodedJpegFrame) {
  auto server = start();
  const std::string common = "request " + address(*server) + " --dataset sparse --scene " + scene();
  auto r = test::runVoxbrick(common + " --encoding png -o " + (scratch() / "png.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  r = test::runVoxbrick(common + " --encoding jpeg -o " + (scratch() / "jpeg.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("as jpeg"), std::string::npos) << r.output;
  const image::Image8 lossless = image::readPng(scratch() / "png.png");
  const image::Image8 decoded = image::readPng(scratch() / "jpeg.png");
  ASSERT_EQ(decoded.width, 96);
  ASSERT_EQ(decoded.height, 80);
  EXPECT_GE(psnr(decoded, lossless), 30.0);
  EXPECT_NE(decoded.rgba, lossless.rgba) << "a jpeg frame is lossy";

  // Into a .jpg the frame is written as it came, at the quality asked of the server.
  r = test::runVoxbrick(common + " --encoding jpeg --jpeg-quality 40 -o " + (scratch() / "q40.jpg").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  r = test::runVoxbrick(common + " --encoding jpeg --jpeg-quality 95 -o " + (scratch() / "q95.jpg").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const auto q40 = test::readFile(scratch() / "q40.jpg"), q95 = test::readFile(scratch() / "q95.jpg");
  ASSERT_GE(q40.size(), 2u);
  EXPECT_EQ(uint8_t(q40[0]), 0xFF);
  EXPECT_EQ(uint8_t(q40[1]), 0xD8);
  EXPECT_LT(q40.size(), q95.size());
  EXPECT_LT(psnr(image::readImage(scratch() / "q40.jpg"), lossless),
            psnr(image::readImage(scratch() / "q95.jpg"), lossless));

  // A transparent frame cannot travel as jpeg: the server's refusal names the key.
  r = test::runVoxbrick(common + " --encoding jpeg --background none -o " + (scratch() / "none.png").string());
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("InvalidScene"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("'background'"), std::string::npos) << r.output;
}

TEST_F(RequestJpegTest, LoadAndThePythonClientUseJpeg) {
  auto server = start();
  const auto report = scratch() / "load.json";
  auto r = test::runVoxbrick("load " + address(*server) +
                             " --dataset sparse --clients 1 --duration 1 --size 64x64 --encoding jpeg --json " +
                             report.string() + " --require-clean");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const std::vector<char> text = test::readFile(report);
  const json load = json::parse(std::string(text.begin(), text.end()));
  EXPECT_EQ(load["encoding"], "jpeg");
  EXPECT_GT(load["frames"].get<int>(), 0);
  EXPECT_GT(load["payload_bytes_per_frame"].get<double>(), 0);

  r = test::runShell(std::string("python3 ") + VOXBRICK_SOURCE_DIR + "/examples/python/voxbrick_client.py " +
                     address(*server) + " --dataset sparse --scene " + scene() + " --encoding jpeg -o " +
                     (scratch() / "python.jpg").string() + " 2>&1");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const image::Image8 python = image::readImage(scratch() / "python.jpg");
  EXPECT_EQ(python.width, 96);
  EXPECT_EQ(python.height, 80);
}

TEST_F(RequestJpegTest, DraggingClientsAskForJpegProvisionalFrames) {
  auto server = start();
  const auto report = scratch() / "drag.json";
  auto r = test::runVoxbrick("load " + address(*server) +
                             " --dataset sparse --clients 2 --duration 1 --size 64x64 --drag 20 --encoding png "
                             "--provisional-encoding jpeg --json " +
                             report.string() + " --require-clean");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const std::vector<char> text = test::readFile(report);
  const json load = json::parse(std::string(text.begin(), text.end()));
  EXPECT_GT(load["frames"].get<int>(), 0);
  EXPECT_EQ(load["errors"].get<int>(), 0);
  // Counted apart from the frames: first replies that were provisional, and the exact frames that followed them.
  EXPECT_TRUE(load.contains("provisional")) << load.dump();
  EXPECT_TRUE(load.contains("exact_followups")) << load.dump();
}

}  // namespace
}  // namespace voxbrick
