// Interactive sessions end to end on the real `voxbrick serve` process: an interactive Render is answered by a frame
// within its time budget (provisional) and then, once the camera rests, by the exact frame; a newer Render drops that
// refinement; and a heavy frame given up (its session gone, or its refinement overtaken) frees the render thread at
// once, whatever its size and step.
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <thread>
#include <tuple>

#include <nlohmann/json.hpp>

#include "ServerProcess.h"
#include "client/Client.h"
#include "image/FrameImage.h"
#include "image/Image.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using client::Client;
using nlohmann::json;
using test::ServerProcess;
using Clock = std::chrono::steady_clock;

class InteractiveServerTest : public test::SparseDatasetSuite {
 protected:
  std::unique_ptr<ServerProcess> start() {
    return serve("--render-threads 1");
  }
};

std::unique_ptr<Client> interactiveSession(const ServerProcess& server, uint16_t maxVersion = proto::kMaxVersion) {
  auto c = std::make_unique<Client>("127.0.0.1", server.port(), std::chrono::seconds(60));
  c->hello("test", maxVersion);
  c->openDataset("sparse");
  return c;
}

std::string scene(double azimuth, bool interactive, int side = 192, double step = 0.75) {
  json s = {{"camera", {{"orbit", {azimuth, 25, 2.2}}}},
            {"size", {side, side}},
            {"transfer_function", "sparse"},
            {"step", step}};
  if (interactive) s["interactive"] = true, s["time_budget_ms"] = 10;
  return s.dump();
}

double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

std::vector<uint8_t> interactivePixels(const proto::Frame& frame) { return image::decodeFrameImage(frame).rgba; }


TEST_F(InteractiveServerTest, AnInteractiveRenderGetsAProvisionalFrameThenTheExactOne) {
  auto server = start();
  auto c = interactiveSession(*server);
  std::vector<proto::Frame> provisional;
  const auto sent = Clock::now();
  double provisionalMs = 0;
  const proto::Frame exact = c->render(scene(40, true), proto::Encoding::RawRgba8, [&](const proto::Frame& f) {
    provisional.push_back(f);
    provisionalMs = msSince(sent);
  });
  const double exactMs = msSince(sent);
  ASSERT_EQ(provisional.size(), 1u);
  const json first = json::parse(provisional[0].statsJson), last = json::parse(exact.statsJson);
  EXPECT_TRUE(first["provisional"].get<bool>());
  ASSERT_TRUE(first["interactive"].is_object()) << first.dump();
  EXPECT_EQ(first["interactive"]["budget_ms"].get<double>(), 10);
  EXPECT_LT(first["interactive"]["scale"].get<double>(), 1) << "a new session's first frame measures the device";
  EXPECT_EQ(provisional[0].width, first["interactive"]["width"].get<uint32_t>()) << "sent as drawn (version 8)";
  EXPECT_EQ(provisional[0].height, first["interactive"]["height"].get<uint32_t>());
  EXPECT_LT(provisional[0].width, 192u);
  EXPECT_FALSE(last["provisional"].get<bool>());
  EXPECT_FALSE(last.contains("interactive"));
  // The exact frame waits for the camera to rest, and comes within the rest's cap of the provisional one (plus its
  // own drawing).
  EXPECT_GE(exactMs - provisionalMs, 100) << "the exact frame waited for the rest";
  EXPECT_NE(interactivePixels(provisional[0]), interactivePixels(exact));
  // The exact frame is a plain Render's.
  EXPECT_EQ(interactivePixels(c->render(scene(40, false), proto::Encoding::RawRgba8)), interactivePixels(exact));
  EXPECT_EQ(json::parse(c->stats())["renders"]["refined"].get<int>(), 1);

  // The session's second interactive frame is predicted at its own rate.
  const proto::Frame second = c->render(scene(50, true), proto::Encoding::RawRgba8, [&](const proto::Frame& f) {
    const json s = json::parse(f.statsJson);
    EXPECT_GT(s["interactive"]["rate_samples_per_ms"].get<double>(), 0) << s.dump();
    EXPECT_GT(s["interactive"]["predicted_ms"].get<double>(), 0) << s.dump();
  });
  EXPECT_FALSE(json::parse(second.statsJson)["provisional"].get<bool>());
}

// Version 8 sends a provisional frame as drawn, for every still encoding; an older session gets the same drawing scaled
// up to its scene's size by the server. The exact frame is the scene's size either way.
TEST_F(InteractiveServerTest, AProvisionalFrameGoesAsDrawnFromVersionEightAndScaledUpBefore) {
  for (const proto::Encoding encoding : {proto::Encoding::RawRgba8, proto::Encoding::Png, proto::Encoding::Jpeg}) {
    SCOPED_TRACE(proto::encodingName(encoding));
    std::map<int, proto::Frame> provisional, exact;
    for (const int version : {8, 7}) {
      // A fresh server each: a session's first interactive frame on a render thread that has drawn nothing is the
      // cheapest drawing (64 pixels a side), the same for both versions.
      auto server = start();
      auto c = interactiveSession(*server, uint16_t(version));
      ASSERT_EQ(c->version(), version);
      exact[version] = c->render(scene(40, true), encoding, [&](const proto::Frame& f) { provisional[version] = f; });
    }
    ASSERT_EQ(provisional.size(), 2u);
    const json drawn = json::parse(provisional[8].statsJson)["interactive"];
    ASSERT_EQ(drawn["width"], 64) << drawn;
    EXPECT_EQ(json::parse(provisional[7].statsJson)["interactive"]["width"], 64);
    EXPECT_EQ(provisional[8].width, 64u) << "sent as drawn";
    EXPECT_EQ(provisional[8].height, 64u);
    EXPECT_EQ(provisional[7].width, 192u) << "scaled up by the server for an older client";
    EXPECT_EQ(provisional[7].height, 192u);
    EXPECT_LT(provisional[8].payload.size(), provisional[7].payload.size());
    // The older session's frame is the newer one's drawing scaled up. JPEG encodes the drawing at two sizes: shown at
    // the scene's size, the one sent as drawn is within 1 dB of the other against the exact frame (the drawing's own
    // loss is most of it).
    const image::Image8 grown = image::scaleImage(image::decodeFrameImage(provisional[8]), 192, 192);
    const image::Image8 older = image::decodeFrameImage(provisional[7]);
    if (encoding == proto::Encoding::Jpeg) {
      const image::ImageF truth = image::toImageF(image::decodeFrameImage(exact[8]));
      const double asDrawn = image::compareImages(image::toImageF(grown), truth).psnr;
      const double scaledUp = image::compareImages(image::toImageF(older), truth).psnr;
      EXPECT_GT(asDrawn, scaledUp - 1) << asDrawn << " dB sent as drawn, " << scaledUp << " dB scaled up first";
    } else {
      EXPECT_EQ(grown.rgba, older.rgba);
    }
    for (const int version : {7, 8}) {
      EXPECT_EQ(exact[version].width, 192u);
      EXPECT_EQ(exact[version].height, 192u);
    }
    EXPECT_EQ(image::decodeFrameImage(exact[8]).rgba, image::decodeFrameImage(exact[7]).rgba);
  }
}

// Two sessions asking the same interactive frame at once, one of version 8 and one older, each get their own kind of
// provisional frame: frame sharing keeps the two apart.
TEST_F(InteractiveServerTest, SharedFramesKeepProvisionalFramesAsDrawnApart) {
  auto server = start();
  auto eight = interactiveSession(*server), seven = interactiveSession(*server, 7);
  for (int round = 0; round < 3; ++round) {
    const uint32_t a = eight->send(proto::RenderRequest{proto::Encoding::Png, scene(40 + round, true)});
    const uint32_t b = seven->send(proto::RenderRequest{proto::Encoding::Png, scene(40 + round, true)});
    for (auto [c, id, version] : {std::tuple{eight.get(), a, 8}, std::tuple{seven.get(), b, 7}}) {
      auto [rid, m] = c->receive();
      ASSERT_EQ(rid, id);
      ASSERT_TRUE(std::holds_alternative<proto::Frame>(m));
      const auto& f = std::get<proto::Frame>(m);
      ASSERT_TRUE(client::isProvisional(f));
      const json drawn = json::parse(f.statsJson)["interactive"];
      if (version == 8)
        EXPECT_EQ(f.width, drawn["width"].get<uint32_t>()) << drawn;
      else
        EXPECT_EQ(f.width, 192u) << drawn;
      auto [rid2, exactFrame] = c->receive();  // the exact frame, once the camera rests
      ASSERT_EQ(rid2, id);
      ASSERT_TRUE(std::holds_alternative<proto::Frame>(exactFrame));
      EXPECT_EQ(std::get<proto::Frame>(exactFrame).width, 192u);
    }
  }
}

TEST_F(InteractiveServerTest, ANewerRenderDropsTheRefinementWithoutAReply) {
  auto server = start();
  auto c = interactiveSession(*server);
  const uint32_t dragged = c->send(proto::RenderRequest{proto::Encoding::RawRgba8, scene(40, true)});
  auto [id, first] = c->receive();
  ASSERT_EQ(id, dragged);
  ASSERT_TRUE(std::holds_alternative<proto::Frame>(first));
  ASSERT_TRUE(client::isProvisional(std::get<proto::Frame>(first)));
  // The camera moves on before the rest is over: the newer Render's frame comes, and nothing more for the first.
  const uint32_t next = c->send(proto::RenderRequest{proto::Encoding::RawRgba8, scene(60, false)});
  std::this_thread::sleep_for(std::chrono::milliseconds(400));  // past any rest
  const uint32_t stats = c->send(proto::GetStats{});
  int framesOfNext = 0;
  for (;;) {
    auto [rid, m] = c->receive();
    EXPECT_NE(rid, dragged) << "the dropped refinement was answered";
    if (rid == next) {
      ASSERT_TRUE(std::holds_alternative<proto::Frame>(m));
      ++framesOfNext;
    }
    if (rid == stats) break;
  }
  EXPECT_EQ(framesOfNext, 1);
  EXPECT_EQ(json::parse(c->stats())["renders"]["refined"].get<int>(), 0);
}

/// A small frame of a fresh session, timed from its Render to its Frame.
double smallFrameMs(const ServerProcess& server) {
  auto c = interactiveSession(server);
  const auto t = Clock::now();
  const proto::Frame f = c->render(scene(10, false, 64), proto::Encoding::RawRgba8);
  EXPECT_EQ(f.width, 64u);
  return msSince(t);
}

// A heavy frame (256², a step of 0.002 voxel: about 300 million samples, seconds on llvmpipe) given up: before, its
// 64-row bands kept the render thread for seconds after the cancellation; now intervals sized by cost free it.
TEST_F(InteractiveServerTest, AHeavyFrameGivenUpFreesTheRenderThreadAtOnce) {
  auto server = start();
  smallFrameMs(*server);  // warm: the device's rate is known
  {
    auto gone = interactiveSession(*server);
    gone->send(proto::RenderRequest{proto::Encoding::Png, scene(30, false, 256, 0.002)});
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // drawing now
  }                                                               // the client leaves without its frame
  // Measured 10 to 12 ms, and 3.7 s with the renderer's passes in their own 64-row bands (checkpointSamples ignored);
  // test_server's tests run one at a time (RUN_SERIAL), so nothing else of the suite loads the machine meanwhile.
  EXPECT_LT(smallFrameMs(*server), 1000) << "the abandoned frame held the render thread";

  // A refinement overtaken while it draws: an interactive heavy Render, whose exact frame starts after the rest, and
  // a newer Render while it draws.
  auto c = interactiveSession(*server);
  const uint32_t heavy = c->send(proto::RenderRequest{proto::Encoding::Png, scene(30, true, 256, 0.002)});
  auto [id, m] = c->receive();
  ASSERT_EQ(id, heavy);
  ASSERT_TRUE(std::holds_alternative<proto::Frame>(m)) << "the provisional frame";
  std::this_thread::sleep_for(std::chrono::milliseconds(600));  // the rest is over: the exact frame draws
  const auto t = Clock::now();
  const proto::Frame small = c->render(scene(10, false, 64), proto::Encoding::RawRgba8);
  EXPECT_LT(msSince(t), 1000) << "the overtaken refinement held the render thread";  // 6 to 45 ms; 3.7 s in bands
  EXPECT_EQ(small.width, 64u);
  const json stats = json::parse(c->stats());
  EXPECT_EQ(stats["renders"]["cancelled"].get<int>(), 2) << stats.dump();
}

}  // namespace
}  // namespace voxbrick
