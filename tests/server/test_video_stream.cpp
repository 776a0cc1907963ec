// A session's video stream with made-up times and bitrates: the stream's scale follows the bitrate the link allows
// (kMinBitsPerPixel), shrinking soon and growing only once the link has held up, each change a key frame of the new
// size that a decoder shows at once.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "image/FrameImage.h"
#include "image/Video.h"
#include "server/VideoStream.h"
#include "support/MadeUpTime.h"

namespace voxbrick::server {
namespace {

using Clock = std::chrono::steady_clock;
using test::at;

/// A provisional vp8 Frame of `side` x `side` RGBA8 pixels, as renderReply leaves it for the stream.
proto::Frame rawFrame(int side, int shade) {
  proto::Frame f;
  f.width = uint32_t(side), f.height = uint32_t(side);
  f.encoding = proto::Encoding::Vp8;
  f.statsJson = "{}";
  f.payload.resize(size_t(side) * size_t(side) * 4);
  for (size_t i = 0; i < f.payload.size(); ++i) f.payload[i] = uint8_t(i % 4 == 3 ? 255 : (i / 4 + shade) % 200);
  return f;
}

TEST(VideoStream, TheScaleIsTheLargestThatGivesEachPixelItsBits) {
  // 1024²: 0.025 bits a pixel at 30 frames a second is 786 kbit/s at full size, 442 at 0.75, 197 at 0.5.
  EXPECT_EQ(VideoStream::scaleFor(4000, 1024, 1024), 1);
  EXPECT_EQ(VideoStream::scaleFor(800, 1024, 1024), 1);
  EXPECT_EQ(VideoStream::scaleFor(700, 1024, 1024), 0.75);
  EXPECT_EQ(VideoStream::scaleFor(300, 1024, 1024), 0.5);
  EXPECT_EQ(VideoStream::scaleFor(120, 1024, 1024), 0.375);
  EXPECT_EQ(VideoStream::scaleFor(1, 1024, 1024), 0.25) << "never smaller than the last scale";
  EXPECT_EQ(VideoStream::scaleFor(300, 256, 256), 1) << "a small frame keeps its size";
}

TEST(VideoStream, ASlowLinkShrinksTheStreamSoonAndAFastOneGrowsItLater) {
  VideoStream stream;
  image::FrameDecoder decoder;
  struct Shown {
    uint32_t side;
    std::string key;
  };
  std::vector<Shown> shown;
  const auto send = [&](double ms, double kbps) {
    proto::Frame f = rawFrame(256, int(ms));
    VideoFrameInput input;
    input.bitrateKbps = kbps, input.drawn = at(ms);
    const VideoEncoded done = stream.encode(f, input);
    const nlohmann::json video = nlohmann::json::parse(f.statsJson)["video"];
    EXPECT_EQ(video["scale"].get<double>() * 256, double(f.width)) << f.statsJson;
    EXPECT_EQ(f.width, f.height);
    const image::Image8 out = decoder.decode(f);  // each frame decodes, at the stream's size
    EXPECT_EQ(uint32_t(out.width), f.width);
    shown.push_back({f.width, done.key ? done.keyReason : "-"});
  };
  // 256² at 30 frames a second: 0.025 bits a pixel is 49 kbit/s; at 20 kbit/s the link calls for 0.5 (12 kbit/s).
  send(0, 400);      // full size
  send(33, 20);      // the link slows: not yet
  send(200, 20);     // still within kShrinkAfterMs
  send(400, 20);     // 367 ms after it slowed: shrink, a key frame of the new size
  send(433, 20);     // on at that size
  send(466, 400);    // fast again: not yet
  send(1500, 400);   // not yet (1034 ms)
  send(2500, 400);   // 2034 ms: grow back
  send(2533, 400);
  const std::vector<std::pair<uint32_t, std::string>> want = {{256, "start"}, {256, "-"}, {256, "-"},  {128, "size"},
                                                              {128, "-"},     {128, "-"}, {128, "-"},  {256, "size"},
                                                              {256, "-"}};
  ASSERT_EQ(shown.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(shown[i].side, want[i].first) << "frame " << i;
    EXPECT_EQ(shown[i].key, want[i].second) << "frame " << i;
  }
}

TEST(VideoStream, AStreamStartsAtTheScaleItsLinkAllows) {
  VideoStream stream;
  proto::Frame f = rawFrame(256, 0);
  VideoFrameInput input;
  input.bitrateKbps = 2, input.drawn = at(0);
  stream.encode(f, input);
  EXPECT_EQ(f.width, 64u) << "2 kbit/s at 256² calls for the smallest scale at once";
}

}  // namespace
}  // namespace voxbrick::server
