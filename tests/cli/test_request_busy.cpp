// `voxbrick request` against a real server that answers Busy: a Render past the address' frame-rate quota, and a
// session refused at Hello while the server drags as many as it keeps (busy_at_hello). The request waits each out by
// the server's hint and writes its frame; `--busy-wait 0` makes the first Busy an error that names it.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include "cli/CliRun.h"
#include "client/Client.h"
#include "image/ImageFile.h"
#include "server/ServerProcess.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

constexpr const char* kScene =
    R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [32, 32], "transfer_function": "sparse")";

size_t occurrences(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

class RequestBusyTest : public test::SparseDatasetSuite {
 protected:
  std::unique_ptr<test::ServerProcess> start(const std::string& toml) {
    const auto config = scratch() / "busy.toml";
    std::ofstream(config) << toml;
    return std::make_unique<test::ServerProcess>(
        "--datasets " + datasets() + " --render-threads 1 --config " + config.string(), scratch());
  }
  static std::string request(const test::ServerProcess& server, const std::string& output) {
    const auto scene = scratch() / "scene.json";
    test::writeFile(scene, kScene + std::string("}"));
    return "request 127.0.0.1:" + std::to_string(server.port()) + " --dataset sparse --scene " + scene.string() +
           " -o " + (scratch() / output).string();
  }
};

// A quota of 0.4 frames a second per address, spent by this test's own session (which keeps the address' bucket):
// the request's Render is Busy, waited out by its hint (under 2.5 s), and its frame is written. With --busy-wait 0
// the same Busy ends the request, naming the quota and its hint.
TEST_F(RequestBusyTest, ARenderPastTheQuotaIsAskedAgainAfterItsHint) {
  auto server = start("[quotas]\nframes_per_s_per_address = 0.4\n");
  client::Client holder("127.0.0.1", server->port());
  holder.hello("test");
  holder.openDataset("sparse");
  holder.render(kScene + std::string("}"));  // the bucket of one frame is spent

  const auto began = std::chrono::steady_clock::now();
  test::SplitResult r = test::runSplit(request(*server, "waited.png"), 60);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
  ASSERT_EQ(r.exitCode, 0) << r.out << r.err;
  EXPECT_NE(r.err.find("frames_per_s_per_address"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("asking again in"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("Busy replies waited out"), std::string::npos) << r.out;
  EXPECT_GE(seconds, 0.4) << "the quota refills 0.4 frames a second: the Busy's hint was waited out";
  const image::Image8 frame = image::readPng(scratch() / "waited.png");
  EXPECT_EQ(frame.width, 32);
  EXPECT_EQ(frame.height, 32);

  // The request's frame spent the bucket again: now the first Busy is the answer.
  r = test::runSplit(request(*server, "refused.png") + " --busy-wait 0", 60);
  EXPECT_EQ(r.exitCode, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("Busy"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("frames_per_s_per_address"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("retry after"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("asking again"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(scratch() / "refused.png"));
}

// busy_at_hello with room for one drag: while this test's session drags, the request's session is refused at Hello
// (the server then closes it). The drag stops once the server has logged the refusal; the request connects again
// after the hint (2 s) and gets its frame. Without waiting it out, the request ends at the first refusal.
TEST_F(RequestBusyTest, ASessionRefusedAtHelloConnectsAgainAfterItsHint) {
  auto server = start("[scheduler]\nbusy_at_hello = true\nmax_interactive_sessions = 1\n");
  client::Client dragger("127.0.0.1", server->port());
  dragger.hello("test");
  dragger.openDataset("sparse");
  const std::string moving = kScene + std::string(R"(, "interactive": true})");
  dragger.render(moving);
  // A moving camera every 100 ms (the session counts as dragging for a second after each) until `stop`: with
  // `untilRefused`, until the server has logged a refusal at Hello too.
  const auto dragWhile = [&](std::atomic<bool>& stop, bool untilRefused) {
    const size_t refusalsBefore = occurrences(server->log(), "refused at Hello");
    return std::thread([&stop, untilRefused, refusalsBefore, &dragger, &moving, &server] {
      for (int i = 0; i < 600 && !stop; ++i) {
        dragger.render(moving);
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        if (untilRefused && occurrences(server->log(), "refused at Hello") > refusalsBefore) stop = true;
      }
    });
  };
  std::atomic<bool> stop = false;
  std::thread drag = dragWhile(stop, true);
  const test::SplitResult r = test::runSplit(request(*server, "hello.png"), 60);
  stop = true;
  drag.join();
  ASSERT_EQ(r.exitCode, 0) << r.out << r.err << server->log();
  EXPECT_NE(r.err.find("Busy"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("asking again in"), std::string::npos) << r.err;
  EXPECT_EQ(image::readPng(scratch() / "hello.png").width, 32);

  // Dragging throughout, a request that waits for nothing is refused at Hello and says so.
  stop = false;
  drag = dragWhile(stop, false);
  const test::SplitResult once = test::runSplit(request(*server, "once.png") + " --busy-wait 0", 60);
  stop = true;
  drag.join();
  EXPECT_EQ(once.exitCode, 1) << once.out << once.err;
  EXPECT_NE(once.err.find("Busy"), std::string::npos) << once.err;
  EXPECT_NE(once.err.find("retry after"), std::string::npos) << once.err;
  EXPECT_FALSE(std::filesystem::exists(scratch() / "once.png"));
}

}  // namespace
}  // namespace voxbrick
