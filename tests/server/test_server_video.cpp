// Protocol version 4's video stream against the real `voxbrick serve` process: the codecs offered, a drag's moving
// frames as one VP8 (or VP9) stream that a client decodes frame by frame in order, key frames where PROTOCOL.md puts
// them, the exact frame after it as png, FrameReceived reports, and the refusals (an older session, a video exact
// frame, a transparent video frame).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "ServerErrorOf.h"
#include "ServerProcess.h"
#include "client/Client.h"
#include "image/FrameImage.h"
#include "image/Image.h"
#include "image/Video.h"

namespace voxbrick {
namespace {

using client::Client;
using client::ServerError;
using nlohmann::json;
using proto::Encoding;
using proto::ErrorCode;
using test::ServerProcess;

class VideoServerTest : public test::SparseDatasetSuite {
 protected:
  std::unique_ptr<ServerProcess> start() {
    return serve("--render-threads 1");
  }
  /// A server of one render thread given `toml` as its configuration file (`name`, in the scratch folder).
  std::unique_ptr<ServerProcess> serveConfigured(const std::string& name, const std::string& toml,
                                                 const std::string& more = "") {
    const auto config = scratch() / name;
    std::ofstream(config) << toml;
    return serve("--render-threads 1 " + more + (more.empty() ? "" : " ") + "--config " + config.string());
  }
};

std::string dragScene(double azimuth, const std::string& codec, int side = 96, const json& extra = {}) {
  json s = {{"camera", {{"orbit", {azimuth, 25, 2.2}}}},
            {"size", {side, side}},
            {"transfer_function", "sparse"},
            {"background", {0.1, 0.1, 0.2}},
            {"interactive", true},
            {"time_budget_ms", 50},
            {"provisional_encoding", codec}};
  if (extra.is_object()) s.update(extra);
  return s.dump();
}

std::unique_ptr<Client> videoSession(const ServerProcess& server, uint16_t maxVersion = proto::kMaxVersion) {
  auto c = std::make_unique<Client>("127.0.0.1", server.port(), std::chrono::seconds(60));
  c->hello("test", maxVersion);
  c->openDataset("sparse");
  return c;
}

/// One Render of an interactive `scene` of `side` x `side` pixels: each Frame decoded in order by `decoder` at its
/// size, the exact frame at the scene's size, and each moving frame with its statistics given to `moving`.
void dragStep(Client& c, image::FrameDecoder& decoder, const std::string& scene, uint32_t side,
              const std::function<void(const proto::Frame&, const json&)>& moving) {
  c.render(scene, Encoding::Png, [&](const proto::Frame& f) {
    const json stats = json::parse(f.statsJson);
    EXPECT_EQ(uint32_t(decoder.decode(f).width), f.width);
    if (!stats["provisional"].get<bool>()) {
      EXPECT_EQ(f.width, side) << "the exact frame";
      return;
    }
    moving(f, stats);
  });
}

TEST_F(VideoServerTest, VersionFourOffersVp8AndVp9AndOlderSessionsDoNot) {
  auto server = start();
  Client c("127.0.0.1", server->port(), std::chrono::seconds(60));
  const proto::Capabilities caps = c.hello("test", 4);
  EXPECT_EQ(caps.version, 4);
  EXPECT_EQ(caps.encodings, proto::encodingsOf(4));
  EXPECT_EQ(Client("127.0.0.1", server->port(), std::chrono::seconds(60)).hello("test", 6).encodings,
            proto::encodingsOf(4))
      << "and every later version up to 6 (7 adds webp)";
  Client old("127.0.0.1", server->port(), std::chrono::seconds(60));
  EXPECT_EQ(old.hello("test", 3).encodings, proto::encodingsOf(3));
  old.openDataset("sparse");
  const ServerError e = test::serverErrorOf([&] { old.render(dragScene(10, "vp8"), Encoding::Png); });
  EXPECT_EQ(e.code(), ErrorCode::InvalidScene);
  EXPECT_NE(std::string(e.what()).find("needs protocol version 4"), std::string::npos) << e.what();
}

// Protocol version 9: a client whose scenes say accepts_vp9_444 gets its vp9 stream in 4:4:4 (VP9's profile 1), said
// in each frame's statistics; dropping the key starts the stream again in 4:2:0 with a key frame; a vp8 stream is
// what it was; an older session is refused the key.
TEST_F(VideoServerTest, AVp9StreamGoesInFourFourFourToAClientThatDecodesIt) {
  auto server = start();
  auto c = videoSession(*server);
  image::FrameDecoder decoder;
  std::vector<std::pair<std::string, json>> seen;  // (chroma, video statistics) of each moving frame
  const auto step = [&](int i, const std::string& codec, bool full) {
    dragStep(*c, decoder, dragScene(10 + 3 * i, codec, 96, full ? json{{"accepts_vp9_444", true}} : json{}), 96,
             [&](const proto::Frame& f, const json& stats) {
               EXPECT_EQ(f.encoding, codec == "vp9" ? Encoding::Vp9 : Encoding::Vp8);
               seen.emplace_back(stats["video"].value("chroma", ""), stats["video"]);
             });
  };
  for (int i = 0; i < 4; ++i) step(i, "vp9", true);
  ASSERT_FALSE(seen.empty());
  for (const auto& [chroma, video] : seen) EXPECT_EQ(chroma, "4:4:4") << video.dump();
  EXPECT_EQ(seen.front().second["key_reason"], "start") << seen.front().second.dump();
  const size_t full = seen.size();
  for (int i = 4; i < 7; ++i) step(i, "vp9", false);
  ASSERT_GT(seen.size(), full);
  EXPECT_EQ(seen[full].first, "4:2:0");
  EXPECT_EQ(seen[full].second.value("key_reason", ""), "codec") << "4:4:4 to 4:2:0 starts the stream again";
  const size_t half = seen.size();
  for (int i = 7; i < 9; ++i) step(i, "vp8", true);  // the key asks nothing of a vp8 stream
  ASSERT_GT(seen.size(), half);
  EXPECT_EQ(seen[half].first, "") << "a vp8 frame names no chroma: " << seen[half].second.dump();
  EXPECT_EQ(seen[half].second.value("key_reason", ""), "codec");
  EXPECT_EQ(decoder.videoFrames(), seen.size()) << "every moving frame decoded";

  auto old = videoSession(*server, 8);
  const ServerError e = test::serverErrorOf(
      [&] { old->render(dragScene(10, "vp9", 96, {{"accepts_vp9_444", true}}), Encoding::Png); });
  EXPECT_EQ(e.code(), ErrorCode::InvalidScene);
  EXPECT_NE(std::string(e.what()).find("'accepts_vp9_444' needs protocol version 9"), std::string::npos) << e.what();
}

// A drag: each Render's provisional frame is the next frame of one stream, decoded in order; the first is a key frame
// and the others are not; the exact frame that follows the last one is a png equal to a plain Render's. Every Frame is
// reported (FrameReceived), as the viewer does.
TEST_F(VideoServerTest, ADragIsOneVideoStreamAndTheExactFrameIsLossless) {
  for (const char* codec : {"vp8", "vp9"}) {
    SCOPED_TRACE(codec);
    auto server = start();
    auto c = videoSession(*server);
    image::FrameDecoder decoder;
    int keys = 0, frames = 0;
    proto::Frame exact;
    for (int i = 0; i < 6; ++i) {
      std::vector<proto::Frame> provisional;
      const uint32_t id = c->send(proto::RenderRequest{Encoding::Png, dragScene(20 + 3 * i, codec)});
      // One Render at a time: its provisional frame, then its exact one once the camera rests.
      for (;;) {
        auto [replyId, message] = c->receive();
        ASSERT_EQ(replyId, id);
        const auto* frame = std::get_if<proto::Frame>(&message);
        ASSERT_NE(frame, nullptr) << proto::messageTypeName(proto::messageType(message));
        c->frameReceived(replyId, *frame);
        const json stats = json::parse(frame->statsJson);
        if (stats["provisional"].get<bool>()) {
          ASSERT_EQ(frame->encoding, proto::encodingFromShortName(codec));
          ASSERT_EQ(frame->width, 96u);
          const image::Image8 shown = decoder.decode(*frame);
          EXPECT_EQ(shown.width, 96);
          EXPECT_EQ(stats["video"]["stream_frame"].get<int>(), frames);
          keys += stats["video"]["key"].get<bool>() ? 1 : 0;
          if (frames == 0) {
            EXPECT_EQ(stats["video"]["key_reason"], "start");
          }
          ++frames;
          continue;
        }
        exact = *frame;
        break;
      }
    }
    EXPECT_EQ(frames, 6);
    EXPECT_EQ(keys, 1) << "one key frame: the stream's first";
    EXPECT_EQ(exact.encoding, Encoding::Png);
    json still = json::parse(dragScene(35, codec));
    still.erase("interactive");
    still.erase("time_budget_ms");
    still.erase("provisional_encoding");
    const proto::Frame plain = c->render(still.dump(), Encoding::Png);
    EXPECT_EQ(image::decodeFrameImage(exact).rgba, image::decodeFrameImage(plain).rgba);
  }
}

// Key frames: on a new size, when the scene asks for one, and not otherwise; the stream goes on across them.
TEST_F(VideoServerTest, KeyFramesComeOnANewSizeAndWhenAsked) {
  auto server = start();
  auto c = videoSession(*server);
  image::FrameDecoder decoder;
  std::vector<std::string> reasons;
  const auto drag = [&](const std::string& scene) {
    c->render(scene, Encoding::Png, [&](const proto::Frame& f) {
      decoder.decode(f);
      const json video = json::parse(f.statsJson)["video"];
      reasons.push_back(video["key"].get<bool>() ? video["key_reason"].get<std::string>() : "-");
    });
  };
  drag(dragScene(10, "vp8"));
  drag(dragScene(12, "vp8"));
  drag(dragScene(14, "vp8", 128));
  drag(dragScene(16, "vp8", 128));
  drag(dragScene(18, "vp8", 128, {{"keyframe", true}}));
  drag(dragScene(20, "vp8", 128));
  EXPECT_EQ(reasons, (std::vector<std::string>{"start", "-", "size", "-", "asked", "-"}));
  EXPECT_EQ(decoder.videoFrames(), 6u);
  // The server's statistics (and /metrics' voxbrick_video_* families) count them.
  const json video = json::parse(c->stats())["video"];
  EXPECT_EQ(video["encoded"]["vp8"]["frames"], 6) << video.dump();
  EXPECT_GT(video["encoded"]["vp8"]["encode_ms_mean"].get<double>(), 0.0);
  EXPECT_EQ(video["encoded"]["vp9"]["frames"], 0);
  EXPECT_EQ(video["key_frames"], (json{{"start", 1}, {"codec", 0}, {"size", 1}, {"dataset", 0}, {"asked", 1},
                                       {"recovery", 0}, {"memory", 0}, {"encoder", 0}}));
  EXPECT_EQ(video["encoders"], 1) << video.dump();
  EXPECT_EQ(video["memory_bytes"], image::videoEncoderBytes(Encoding::Vp8, 128, 128, 1)) << video.dump();
  EXPECT_EQ(video["memory_limit_bytes"], 4096ull << 20) << "the default memory.video_mb";
}

// The encoders' memory (memory.video_mb) holds: a second session's stream finds no room while the first one's moves,
// and its moving frames go as JPEG; once the first has rested a second its encoder is freed for the second's, which
// starts with a key frame; the first, moving again, finds no room in turn.
TEST_F(VideoServerTest, VideoEncodersStayWithinTheirMemory) {
  // One VP8 stream of 96x96 is counted as 0.9 MiB: 1 MiB holds one, not two.
  ASSERT_LT(image::videoEncoderBytes(Encoding::Vp8, 96, 96, 1), 1u << 20);
  ASSERT_GT(2 * image::videoEncoderBytes(Encoding::Vp8, 96, 96, 1), 1u << 20);
  auto server = serve("--render-threads 1 --video-memory 1");
  auto a = videoSession(*server), b = videoSession(*server);
  image::FrameDecoder decoderA, decoderB;
  // Each Render's provisional frame: its encoding, and its key frame's reason or its fallback ("-" for neither).
  const auto drag = [](Client& c, image::FrameDecoder& decoder, double azimuth) {
    std::pair<Encoding, std::string> moving{Encoding::Png, "none"};
    c.render(dragScene(azimuth, "vp8"), Encoding::Png, [&](const proto::Frame& f) {
      const json stats = json::parse(f.statsJson);
      if (!stats["provisional"].get<bool>()) return;
      const image::Image8 shown = decoder.decode(f);
      EXPECT_EQ(shown.width, 96);
      moving.first = f.encoding;
      if (stats.contains("video_fallback")) {
        moving.second = "fallback " + stats["video_fallback"].get<std::string>();
      } else {
        moving.second = stats["video"]["key"].get<bool>() ? stats["video"]["key_reason"].get<std::string>() : "-";
      }
    });
    return moving;
  };
  using Moving = std::pair<Encoding, std::string>;
  EXPECT_EQ(drag(*a, decoderA, 10), (Moving{Encoding::Vp8, "start"}));
  EXPECT_EQ(drag(*a, decoderA, 12), (Moving{Encoding::Vp8, "-"}));
  EXPECT_EQ(drag(*b, decoderB, 10), (Moving{Encoding::Jpeg, "fallback memory"})) << "a's stream moved just now";
  EXPECT_EQ(drag(*a, decoderA, 14), (Moving{Encoding::Vp8, "-"})) << "a's stream goes on";
  std::this_thread::sleep_for(std::chrono::milliseconds(1200));  // a rests: VideoMemory::kIdleMs
  EXPECT_EQ(drag(*b, decoderB, 12), (Moving{Encoding::Vp8, "memory"}));
  EXPECT_EQ(drag(*b, decoderB, 14), (Moving{Encoding::Vp8, "-"}));
  EXPECT_EQ(drag(*a, decoderA, 16), (Moving{Encoding::Jpeg, "fallback memory"})) << "its encoder was freed for b's";
  const json video = json::parse(a->stats())["video"];
  EXPECT_EQ(video["encoders"], 1) << video.dump();
  EXPECT_EQ(video["memory_bytes"], image::videoEncoderBytes(Encoding::Vp8, 96, 96, 1)) << video.dump();
  EXPECT_EQ(video["memory_limit_bytes"], 1u << 20) << video.dump();
  EXPECT_EQ(video["memory_peak_bytes"], image::videoEncoderBytes(Encoding::Vp8, 96, 96, 1)) << "one at any time";
  EXPECT_EQ(video["encoders_freed"], 1) << video.dump();
  EXPECT_EQ(video["jpeg_frames"], 2) << video.dump();
  EXPECT_EQ(video["key_frames"]["memory"], 1) << video.dump();
  EXPECT_EQ(video["encoded"]["vp8"]["frames"], 5) << video.dump();
}

// Sessions dragging at once, each on its own connection and encoder thread, never hold more than the budget between
// them: those without room get JPEG and every Render is answered.
TEST_F(VideoServerTest, SessionsDraggingAtOnceStayWithinTheVideoMemory) {
  const uint64_t one = image::videoEncoderBytes(Encoding::Vp9, 256, 256, 1);
  ASSERT_LT(2 * one, 40u << 20);
  ASSERT_GT(3 * one, 40u << 20) << "40 MiB holds two VP9 streams of 256x256";
  auto server = serve("--render-threads 2 --video-memory 40");  // and config/server.toml's two encoder threads
  constexpr int kSessions = 5, kFrames = 6;
  std::vector<std::thread> sessions;
  std::vector<std::string> failures(kSessions);
  std::vector<int> videoFrames(kSessions, 0), jpegFrames(kSessions, 0);
  for (int s = 0; s < kSessions; ++s)
    sessions.emplace_back([&, s] {
      try {
        auto c = videoSession(*server);
        image::FrameDecoder decoder;
        for (int i = 0; i < kFrames; ++i)
          c->render(dragScene(10 + 2 * i, "vp9", 256), Encoding::Png, [&](const proto::Frame& f) {
            decoder.decode(f);  // every frame of the stream, in order; the JPEG ones too
            ++(f.encoding == Encoding::Vp9 ? videoFrames : jpegFrames)[size_t(s)];
          });
      } catch (const std::exception& e) {
        failures[size_t(s)] = e.what();
      }
    });
  for (auto& t : sessions) t.join();
  for (int s = 0; s < kSessions; ++s) EXPECT_EQ(failures[size_t(s)], "") << "session " << s;
  int video = 0, jpeg = 0;
  for (int s = 0; s < kSessions; ++s) video += videoFrames[size_t(s)], jpeg += jpegFrames[size_t(s)];
  EXPECT_EQ(video + jpeg, kSessions * kFrames) << "a moving frame for every Render";
  EXPECT_GT(video, 0);
  EXPECT_GT(jpeg, 0) << "five streams cannot all have room";
  auto c = videoSession(*server);
  const json stats = json::parse(c->stats())["video"];
  EXPECT_LE(stats["memory_peak_bytes"].get<uint64_t>(), 40u << 20) << stats.dump();
  EXPECT_LE(stats["memory_peak_bytes"].get<uint64_t>(), 2 * one) << stats.dump();
  EXPECT_EQ(stats["jpeg_frames"].get<int>(), jpeg) << stats.dump();
  EXPECT_EQ(stats["encoded"]["vp9"]["frames"].get<int>(), video) << stats.dump();
}

// The crowd's ladder reaches the encoders: a stream whose frames take longer to encode than its share of the encoder
// threads (one thread, interactive_fps 1000: a millisecond a frame, which no 512x512 VP9 frame is encoded in) is sent
// smaller, with a key frame of its new size, and says why; the exact frame keeps the scene's size.
TEST_F(VideoServerTest, AStreamSlowerThanItsShareOfTheEncodersIsSentSmaller) {
  // (The same share of the render threads leaves the drawing small too: the stream would follow it down before the
  // encoders' cost is measured. stream_follows_drawing = false keeps the stream's size to its link and encoders.)
  auto server = serveConfigured("encoder-share.toml", "[server]\nencode_threads = 1\n[scheduler]\ninteractive_fps = "
                                                      "1000\nstream_follows_drawing = false\n");
  auto c = videoSession(*server);
  image::FrameDecoder decoder;
  uint32_t smallest = 512;
  int smaller = 0, frames = 0, sizeKeys = 0;
  for (int i = 0; i < 8 && (smaller == 0 || frames <= smaller + 1); ++i)
    c->render(dragScene(10 + 2 * i, "vp9", 512), Encoding::Png, [&](const proto::Frame& f) {
      const json stats = json::parse(f.statsJson);
      const image::Image8 shown = decoder.decode(f);
      EXPECT_EQ(uint32_t(shown.width), f.width);
      if (!stats["provisional"].get<bool>()) {
        EXPECT_EQ(f.width, 512u) << "the exact frame";
        return;
      }
      ++frames;
      const json& video = stats["video"];
      if (video.value("key_reason", "") == "size") ++sizeKeys;
      if (f.width < 512) {
        EXPECT_EQ(video.value("scaled_for", ""), "encoders") << f.statsJson;
        EXPECT_EQ(video["scale"].get<double>() * 512, double(f.width)) << f.statsJson;
        if (smaller++ == 0) {
          EXPECT_EQ(video.value("key_reason", ""), "size") << "a key frame of its new size";
        }
        smallest = std::min(smallest, f.width);
      } else {
        EXPECT_FALSE(video.contains("scaled_for")) << f.statsJson;
      }
    });
  EXPECT_GT(smaller, 0) << "every moving frame went at 512x512";
  EXPECT_LT(smallest, 512u);
  const json video = json::parse(c->stats())["video"];
  EXPECT_EQ(video["scaled_frames"]["encoders"], smaller) << video.dump();
  EXPECT_EQ(video["scaled_frames"]["drawing"], 0) << video.dump();
  EXPECT_EQ(video["scaled_frames"]["link"], 0) << video.dump();
  EXPECT_GE(sizeKeys, 1);
  EXPECT_EQ(video["key_frames"]["size"], sizeKeys) << video.dump();
}

// A stream sent smaller than its scene has its moving frames drawn at its size, not drawn at the scene's and shrunk:
// a VP8 encoder of 512x512 (12 MiB) is more than a quarter of 16 MiB of video memory, so the stream goes at 256x256
// from its first frame; the frames after it are drawn at 256x256 (interactive_fps 0.5 leaves the budget of
// 2 s the scene asks, and the exact drawing fits it), and the exact frame is the scene's 512x512.
TEST_F(VideoServerTest, AStreamSentSmallerHasItsMovingFramesDrawnAtItsSize) {
  ASSERT_GT(image::videoEncoderBytes(Encoding::Vp8, 384, 384, 1), 4u << 20);
  ASSERT_LT(image::videoEncoderBytes(Encoding::Vp8, 256, 256, 1), 4u << 20);
  auto server = serveConfigured("slow-crowd.toml", "[scheduler]\ninteractive_fps = 0.5\n", "--video-memory 16");
  auto c = videoSession(*server);
  image::FrameDecoder decoder;
  std::vector<std::pair<int, uint32_t>> moving;  // each moving frame's drawn width and sent width
  for (int i = 0; i < 4; ++i)
    dragStep(*c, decoder, dragScene(10 + 2 * i, "vp8", 512, {{"time_budget_ms", 2000}}), 512,
             [&](const proto::Frame& f, const json& stats) {
               EXPECT_EQ(stats["video"].value("scaled_for", ""), "memory") << f.statsJson;
               moving.emplace_back(stats["interactive"]["width"].get<int>(), f.width);
             });
  ASSERT_EQ(moving.size(), 4u);
  for (const auto& [drawn, sent] : moving) EXPECT_EQ(sent, 256u);
  // The first was drawn before the stream had a size (at the cheapest rung, which measures the device); the rest at
  // the stream's size, the exact drawing.
  for (size_t i = 1; i < moving.size(); ++i) EXPECT_EQ(moving[i].first, 256) << "frame " << i;
}

// A stream whose moving frames the time budget leaves drawn smaller than the stream follows its drawing down: a
// budget of 10 ms draws 512² at a fraction of its sides on llvmpipe, so the stream goes smaller than 512²
// (`scaled_for` `drawing`), never smaller than its drawing or than 256 pixels a side, and its frames are drawn at
// most at its size. Given a budget that draws the whole scene, it grows back to 512². (interactive_fps 0.5 leaves
// each frame the budget its scene asks.)
TEST_F(VideoServerTest, AStreamFollowsItsDrawingDownAndBackUp) {
  auto server = serveConfigured("slow-crowd.toml", "[scheduler]\ninteractive_fps = 0.5\n");
  auto c = videoSession(*server);
  image::FrameDecoder decoder;
  uint32_t sent = 512;
  int smaller = 0, frames = 0;
  const auto drag = [&](int i, double budgetMs) {
    dragStep(*c, decoder, dragScene(10 + 2 * i, "vp8", 512, {{"time_budget_ms", budgetMs}}), 512,
             [&](const proto::Frame& f, const json& stats) {
               ++frames;
               const json& video = stats["video"];
               EXPECT_LE(stats["interactive"]["width"].get<uint32_t>(), sent) << "drawn no larger than its stream";
               if (f.width < sent) {
                 EXPECT_EQ(video.value("key_reason", ""), "size") << f.statsJson;
                 EXPECT_GE(video["scale"].get<double>() + 1e-3, stats["interactive"]["scale_wanted"].get<double>())
                     << "made smaller than its drawing: " << f.statsJson;
               }
               sent = f.width;
               if (f.width < 512) {
                 ++smaller;
                 EXPECT_EQ(video.value("scaled_for", ""), "drawing") << f.statsJson;
                 EXPECT_GE(f.width, 256u) << f.statsJson;
               }
             });
  };

  for (int i = 0; i < 12 && smaller < 2; ++i) drag(i, 10);
  ASSERT_GE(smaller, 2) << "every moving frame of a 10 ms budget went at 512x512";
  const int shrunkAt = frames;
  for (int i = 0; i < 40 && sent < 512; ++i) drag(20 + i, 5000);
  EXPECT_EQ(sent, 512u) << "the stream did not grow back";
  const json video = json::parse(c->stats())["video"];
  EXPECT_EQ(video["scaled_frames"]["drawing"], smaller) << video.dump();
  EXPECT_GE(video["key_frames"]["size"], 2) << "down and back up: " << video.dump();
  EXPECT_GT(frames, shrunkAt);
}

// A crowd of video streams that has gone gives its encoders' memory back to the system: the server's resident size
// returns near where it was before they came (glibc would keep the freed blocks in its arenas otherwise).
TEST_F(VideoServerTest, StreamsThatHaveGoneGiveTheirEncodersMemoryBack) {
  // (Streams of the scene's size: not made smaller for their drawings, which the crowd's budget keeps small.)
  auto server = serveConfigured("whole-streams.toml", "[scheduler]\nstream_follows_drawing = false\n");
  const auto rss = [&] {
    auto c = videoSession(*server);
    return json::parse(c->stats())["memory"]["rss_bytes"].get<double>();
  };
  {
    auto warm = videoSession(*server);  // the renderer, its atlas and the dataset's bricks, before anything is measured
    warm->render(dragScene(10, "png", 1024));
  }
  const double before = rss();
  {
    std::vector<std::unique_ptr<Client>> sessions;
    std::vector<image::FrameDecoder> decoders(4);
    for (int s = 0; s < 4; ++s) sessions.push_back(videoSession(*server));
    for (int i = 0; i < 2; ++i)
      for (int s = 0; s < 4; ++s)  // each a VP9 stream of 1024x1024: about 100 MiB of encoder
        sessions[size_t(s)]->render(dragScene(10 + 2 * i, "vp9", 1024),
                                    Encoding::Png, [&](const proto::Frame& f) { decoders[size_t(s)].decode(f); });
  }
  const double during = json::parse(videoSession(*server)->stats())["memory"]["peak_rss_bytes"].get<double>();
  ASSERT_GT(during - before, 200e6) << "four encoders held that much at their peak";
  // The sessions are closed; the server notices and frees them within a moment.
  double after = rss();
  for (int i = 0; i < 50 && after - before > 0.25 * (during - before); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    after = rss();
  }
  EXPECT_LT(after - before, 0.25 * (during - before))
      << "resident before " << before / 1e6 << " MB, at the peak " << during / 1e6 << ", after " << after / 1e6;
}

TEST_F(VideoServerTest, VideoIsRefusedWhereItCannotServe) {
  auto server = start();
  auto c = videoSession(*server);
  json still = json::parse(dragScene(10, "vp8"));
  still.erase("provisional_encoding");
  ServerError e = test::serverErrorOf([&] { c->render(still.dump(), Encoding::Vp8); });
  EXPECT_EQ(e.code(), ErrorCode::InvalidScene);
  EXPECT_NE(std::string(e.what()).find("provisional_encoding"), std::string::npos) << e.what();
  e = test::serverErrorOf([&] { c->render(dragScene(10, "vp9", 96, {{"background", "none"}}), Encoding::Png); });
  EXPECT_EQ(e.code(), ErrorCode::InvalidScene);
  EXPECT_NE(std::string(e.what()).find("'background'"), std::string::npos) << e.what();
  // The session goes on.
  EXPECT_EQ(c->render(dragScene(10, "vp9"), Encoding::Png).encoding, Encoding::Png);
}

}  // namespace
}  // namespace voxbrick
