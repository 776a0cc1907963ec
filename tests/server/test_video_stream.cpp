// A session's video stream with made-up times and bitrates: the stream's scale follows the bitrate the link allows
// (kMinBitsPerPixel), shrinking soon and growing only once the link has held up, each change a key frame of the new
// size that a decoder shows at once; and the ledger of the streams' encoder memory (VideoMemory), which frees the
// encoders of resting streams, least recently used first, for a new one, and leaves a busy one alone; and the
// stream's scale where its frames take more than its share of the encoder threads, or where its frames are drawn
// smaller than it.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "image/FrameImage.h"
#include "image/Video.h"
#include "server/FrameClass.h"
#include "server/VideoMemory.h"
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

/// An encoder's holder that counts what it was asked to free, and that may be busy encoding.
struct FakeHolder final : VideoMemory::Holder {
  bool busy = false;
  int freed = 0;
  bool freeEncoder() override {
    if (busy) return false;
    ++freed;
    return true;
  }
};

TEST(VideoMemory, RestingStreamsAreFreedLeastRecentlyUsedFirstAndMovingOnesNever) {
  VideoMemory memory(100);
  FakeHolder a, b, c, d;
  EXPECT_TRUE(memory.reserve(a, 40, at(0)));
  EXPECT_TRUE(memory.reserve(b, 40, at(100)));
  EXPECT_EQ(memory.bytes(), 80u);
  EXPECT_EQ(memory.encoders(), 2u);
  // Both moved within the last second: no room for c.
  EXPECT_FALSE(memory.reserve(c, 40, at(900)));
  EXPECT_EQ(a.freed + b.freed, 0);
  EXPECT_EQ(memory.refused(), 1u);
  // b keeps moving; a has rested a second: a is freed for c.
  memory.used(b, at(1050));
  EXPECT_TRUE(memory.reserve(c, 40, at(1100)));
  EXPECT_EQ(a.freed, 1);
  EXPECT_EQ(b.freed, 0);
  EXPECT_EQ(memory.bytes(), 80u);
  EXPECT_EQ(memory.freed(), 1u);
  EXPECT_TRUE(memory.reserve(d, 20, at(2080))) << "80 + 20 fit without freeing any";
  EXPECT_EQ(b.freed + c.freed, 0);
  // b (last used at 1050) and c (1100) have rested a second at 2120; d has not. The one used longest ago goes.
  EXPECT_TRUE(memory.reserve(a, 30, at(2120)));
  EXPECT_EQ(b.freed, 1);
  EXPECT_EQ(c.freed, 0) << "freeing b made room enough";
  EXPECT_EQ(memory.bytes(), 90u);
  // A holder that asks again (a new size) is counted for its new encoder only: 20 + 40 + 50 > 100 frees c.
  EXPECT_TRUE(memory.reserve(a, 50, at(2130)));
  EXPECT_EQ(c.freed, 1);
  EXPECT_EQ(memory.bytes(), 70u);
  EXPECT_EQ(memory.peakBytes(), 100u) << "b, c and d together at 2080";
  EXPECT_EQ(memory.encoders(), 2u);
  EXPECT_EQ(memory.freed(), 3u);
}

TEST(VideoMemory, AnEncoderBeingUsedIsNotFreedAndAReleaseGivesItsRoomBack) {
  VideoMemory memory(100);
  FakeHolder a, b;
  EXPECT_TRUE(memory.reserve(a, 70, at(0)));
  a.busy = true;  // encoding a frame at this moment
  EXPECT_FALSE(memory.reserve(b, 70, at(5000)));
  EXPECT_EQ(a.freed, 0);
  EXPECT_EQ(memory.freed(), 0u);
  memory.release(a);  // its session ended
  EXPECT_EQ(memory.bytes(), 0u);
  EXPECT_TRUE(memory.reserve(b, 70, at(5001)));
  EXPECT_FALSE(memory.reserve(a, 101, at(9000))) << "larger than the whole budget";
  EXPECT_EQ(b.freed, 1) << "freed in the attempt, which did not fit even so";
  EXPECT_EQ(memory.encoders(), 0u);
  VideoMemory none(0);
  EXPECT_FALSE(none.reserve(a, 1, at(0))) << "memory.video_mb = 0: every moving frame as JPEG";
}

TEST(VideoMemory, AStreamWithNoRoomLeavesItsFrameAndStartsWithAKeyFrameOnceThereIs) {
  // Two real streams of 64x64 VP8 and room for one. A frame with no room is left as it came, its pixels, for the
  // session to send as JPEG (VideoServerTest.VideoEncodersStayWithinTheirMemory holds what the client gets).
  VideoMemory memory(image::videoEncoderBytes(proto::Encoding::Vp8, 64, 64, 1) * 3 / 2);
  VideoStream first(&memory), second(&memory);
  const auto send = [](VideoStream& stream, int shade) {
    proto::Frame f = rawFrame(64, shade);
    const proto::Frame before = f;
    VideoFrameInput input;
    input.bitrateKbps = 500, input.drawn = Clock::now();
    const VideoEncoded done = stream.encode(f, input);
    if (done.noRoom) {
      EXPECT_EQ(f.encoding, proto::Encoding::Vp8);
      EXPECT_EQ(f.payload, before.payload) << "the pixels, untouched";
      EXPECT_EQ(f.statsJson, before.statsJson);
      return std::string("no room");
    }
    return done.key ? done.keyReason : std::string("-");
  };
  EXPECT_EQ(send(first, 0), "start");
  EXPECT_EQ(send(second, 0), "no room");
  EXPECT_EQ(send(first, 1), "-");
  EXPECT_EQ(memory.refused(), 1u);
  EXPECT_EQ(memory.encoders(), 1u);
  // (VideoStream's frames are timed by the clock: the ledger's second of rest is waited for here.)
  std::this_thread::sleep_for(VideoMemory::kIdleMs + std::chrono::milliseconds(50));
  EXPECT_EQ(send(second, 1), "memory");
  EXPECT_EQ(send(second, 2), "-");
  EXPECT_EQ(memory.freed(), 1u);
  EXPECT_EQ(send(first, 2), "no room") << "its encoder was freed for the second's";
}

// The measured choices a stream's encoder is made with: a vp9 stream in 4:4:4 without adaptive quantisation (8 % fewer
// bytes at JPEG q85's PSNR), in 4:2:0 with cyclic refresh (2-4 %; bench/results/video/video-444.md); the threads
// image::videoThreadsFor gives the size.
TEST(VideoStream, AFourFourFourStreamIsEncodedWithoutAdaptiveQuantisation) {
  const auto full = VideoStream::encoderSettings(proto::Encoding::Vp9, 1024, 768, 3000, true);
  EXPECT_TRUE(full.fullChroma);
  EXPECT_EQ(full.aqMode, 0);
  EXPECT_EQ(full.width, 1024);
  EXPECT_EQ(full.height, 768);
  EXPECT_EQ(full.bitrateKbps, 3000);
  const auto half = VideoStream::encoderSettings(proto::Encoding::Vp9, 1024, 768, 3000, false);
  EXPECT_FALSE(half.fullChroma);
  EXPECT_EQ(half.aqMode, 3);
  EXPECT_EQ(half.threads, full.threads);
  EXPECT_EQ(half.threads, image::videoThreadsFor(proto::Encoding::Vp9, 1024, 768,
                                                 int(std::thread::hardware_concurrency())));
  EXPECT_FALSE(VideoStream::encoderSettings(proto::Encoding::Vp8, 512, 512, 1000, false).fullChroma);
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

// The server draws a stream's moving frames at the stream's size (RenderJob::outputScale): such a frame goes as it
// came; one of another size (drawn before the stream changed its size, or at a smaller rung) is scaled to the
// stream's. The stream's size follows the scene's, not the frame's.
TEST(VideoStream, AFrameDrawnAtTheStreamsSizeGoesAsItCameAndOneOfAnotherSizeIsScaledToIt) {
  VideoStream stream;
  image::FrameDecoder decoder;
  EXPECT_EQ(stream.scale(), 1) << "before any frame";
  const auto send = [&](int drawnSide, double ms, double kbps) {
    proto::Frame f = rawFrame(drawnSide, 0);
    VideoFrameInput input;
    input.bitrateKbps = kbps, input.drawn = at(ms);
    input.sceneWidth = input.sceneHeight = 256;
    const VideoEncoded done = stream.encode(f, input);
    const nlohmann::json video = nlohmann::json::parse(f.statsJson)["video"];
    EXPECT_EQ(video["scale"].get<double>() * 256, double(f.width)) << f.statsJson;
    EXPECT_EQ(stream.scale(), video["scale"].get<double>());
    EXPECT_EQ(decoder.decode(f).width, int(f.width));
    return std::make_pair(f.width, done.key ? done.keyReason : "-");
  };
  // 20 kbit/s calls for half the scene's 256² (not half of the frame's): a first frame drawn at the scene's size.
  EXPECT_EQ(send(256, 0, 20), std::make_pair(128u, std::string("start")));
  EXPECT_EQ(send(128, 33, 20), std::make_pair(128u, std::string("-"))) << "drawn at the stream's size";
  EXPECT_EQ(send(64, 66, 20), std::make_pair(128u, std::string("-"))) << "drawn smaller still: scaled up";
  // Fast again for more than kGrowAfterMs: the frame drawn at the old size is scaled up to the new one.
  EXPECT_EQ(send(128, 100, 400), std::make_pair(128u, std::string("-")));
  EXPECT_EQ(send(128, 2200, 400), std::make_pair(256u, std::string("size")));
  EXPECT_EQ(stream.scale(), 1);
  EXPECT_EQ(send(256, 2233, 400), std::make_pair(256u, std::string("-")));
}

TEST(VideoStream, AStreamStartsAtTheScaleItsLinkAllows) {
  VideoStream stream;
  proto::Frame f = rawFrame(256, 0);
  VideoFrameInput input;
  input.bitrateKbps = 2, input.drawn = at(0);
  stream.encode(f, input);
  EXPECT_EQ(f.width, 64u) << "2 kbit/s at 256² calls for the smallest scale at once";
}

TEST(VideoMemory, TheStreamsMovingAreThoseWithAFrameWithinTheIdleTime) {
  VideoMemory memory(1 << 30);
  FakeHolder a, b, c;
  EXPECT_EQ(memory.moving(at(0)), 0u);
  ASSERT_TRUE(memory.reserve(a, 1, at(0)));
  ASSERT_TRUE(memory.reserve(b, 1, at(0)));
  ASSERT_TRUE(memory.reserve(c, 1, at(0)));
  memory.used(a, at(900));
  memory.used(b, at(1500));
  EXPECT_EQ(memory.moving(at(1500)), 2u) << "c's last frame is 1.5 s old";
  EXPECT_EQ(memory.moving(at(2000)), 1u) << "a's is 1.1 s old";
  memory.release(b);
  EXPECT_EQ(memory.moving(at(2000)), 0u);
  // What the last stream measured in each codec, for a stream's first frame.
  EXPECT_EQ(memory.msForAMegapixel(proto::Encoding::Vp9), 0);
  memory.measured(proto::Encoding::Vp9, false, 40);
  memory.measured(proto::Encoding::Vp8, false, 12);
  EXPECT_EQ(memory.msForAMegapixel(proto::Encoding::Vp9), 40);
  EXPECT_EQ(memory.msForAMegapixel(proto::Encoding::Vp8), 12);
  EXPECT_EQ(memory.msForAMegapixel(proto::Encoding::Vp9, true), 0) << "VP9 in 4:4:4 is measured apart";
  memory.measured(proto::Encoding::Vp9, true, 55);
  EXPECT_EQ(memory.msForAMegapixel(proto::Encoding::Vp9, true), 55);
  EXPECT_EQ(memory.msForAMegapixel(proto::Encoding::Vp9), 40);
}

TEST(VideoStream, TheEncodersShareIsTheirTimeOverTheStreamsMoving) {
  EXPECT_EQ(frameShareMs(2, 10, 16), 12.5) << "two threads, 16 streams at 10 frames a second";
  EXPECT_EQ(frameShareMs(2, 10, 1), 200);
  EXPECT_EQ(frameShareMs(2, 10, 0), 200) << "a stream not yet counted counts as one";
  EXPECT_EQ(frameShareMs(8, 20, 4), 100);
}

TEST(VideoStream, TheScaleForTheEncodersIsTheLargestExpectedToEncodeWithinItsShare) {
  constexpr auto Vp8 = proto::Encoding::Vp8, Vp9 = proto::Encoding::Vp9;
  // A smaller frame costs more a pixel: a megapixel's 40 ms in VP9 is 41.2 ms at 1024² (1.05 megapixels), 29.1 at
  // 0.75, 17.9 at 0.5, 12.7 at 0.375 and 7.8 at 0.25 of its sides, not 41.9, 23.6, 10.5, 5.9 and 2.6 as in
  // proportion to the pixels; VP8's time is nearer that proportion: 41.5, 26.9, 14.7, 9.5, 5.2.
  EXPECT_NEAR(VideoStream::expectedMs(Vp9, 40, 1024 * 1024 / 1e6 * 0.25), 17.91, 0.01);
  EXPECT_NEAR(VideoStream::expectedMs(Vp8, 40, 1024 * 1024 / 1e6 * 0.25), 14.65, 0.01);
  EXPECT_EQ(VideoStream::expectedMs(Vp9, 40, 1), 40);
  EXPECT_EQ(VideoStream::scaleForEncoders(Vp9, 40, 12.5, 1024, 1024, 1), 0.25);
  EXPECT_EQ(VideoStream::scaleForEncoders(Vp8, 40, 12.5, 1024, 1024, 1), 0.375);
  EXPECT_EQ(VideoStream::scaleForEncoders(Vp9, 40, 20, 1024, 1024, 1), 0.5);
  EXPECT_EQ(VideoStream::scaleForEncoders(Vp9, 40, 50, 1024, 1024, 1), 1);
  EXPECT_EQ(VideoStream::scaleForEncoders(Vp9, 40, 0.1, 1024, 1024, 1), 0.25) << "never smaller than the last scale";
  EXPECT_EQ(VideoStream::scaleForEncoders(Vp9, 0, 12.5, 1024, 1024, 1), 1) << "a cost not yet measured";
  EXPECT_EQ(VideoStream::scaleForEncoders(Vp9, 40, 0, 1024, 1024, 1), 1) << "no share: no limit";
  // Growing needs room to spare (kGrowWithin): 9 ms for a megapixel is 9.3 ms at full size, within a share of 10 for
  // a stream already at full size, not for one at 0.75 (7.5 ms of room).
  EXPECT_EQ(VideoStream::scaleForEncoders(Vp9, 9, 10, 1024, 1024, 1), 1);
  EXPECT_EQ(VideoStream::scaleForEncoders(Vp9, 9, 10, 1024, 1024, 0.75), 0.75);
}

TEST(VideoStream, AStreamSlowerThanItsShareOfTheEncodersIsSentSmallerAndGrowsBackWhenTheCrowdLeaves) {
  VideoMemory memory(1 << 30);
  VideoStream stream(&memory);
  image::FrameDecoder decoder;
  std::vector<std::pair<uint32_t, std::string>> shown;  // each frame's side, and its key reason or why it is smaller
  const auto send = [&](VideoStream& to, double ms, double shareMs) {
    proto::Frame f = rawFrame(256, int(ms));
    VideoFrameInput input;
    input.bitrateKbps = 2000, input.drawn = at(ms), input.encodeShareMs = shareMs;
    const VideoEncoded done = to.encode(f, input);
    const nlohmann::json video = nlohmann::json::parse(f.statsJson)["video"];
    EXPECT_EQ(video["scale"].get<double>() * 256, double(f.width)) << f.statsJson;
    EXPECT_EQ(decoder.decode(f).width, int(f.width));
    const std::string why = video.contains("scaled_for") ? video["scaled_for"].get<std::string>() : "";
    EXPECT_EQ(why.empty(), done.scaledFor == VideoScaledFor::None);
    shown.emplace_back(f.width, (done.key ? done.keyReason : "-") + (why.empty() ? "" : " " + why));
  };
  // A share of a microsecond: no frame encodes within it, at any size.
  send(stream, 0, 0.001);     // a stream's first frame: its cost is not known yet, full size
  send(stream, 33, 0.001);    // its first inter frame: measured once encoded
  send(stream, 200, 0.001);   // the smallest scale is called for from here, not yet taken
  send(stream, 400, 0.001);   // within kShrinkAfterMs
  send(stream, 550, 0.001);   // shrunk: a key frame of 64x64
  send(stream, 583, 0.001);
  send(stream, 600, 0);       // the crowd has gone (no limit): not yet
  send(stream, 2650, 0);      // 2050 ms later: full size again
  const std::vector<std::pair<uint32_t, std::string>> want = {
      {256, "start"},      {256, "-"},          {256, "-"},          {256, "-"}, {64, "size encoders"},
      {64, "- encoders"}, {64, "- encoders"}, {256, "size"}};
  EXPECT_EQ(shown, want);
  // A newcomer to the crowd starts at the size the cost measured so far calls for.
  VideoStream newcomer(&memory);
  image::FrameDecoder other;
  proto::Frame f = rawFrame(256, 0);
  VideoFrameInput input;
  input.bitrateKbps = 2000, input.drawn = at(0), input.encodeShareMs = 0.001;
  const VideoEncoded done = newcomer.encode(f, input);
  EXPECT_EQ(f.width, 64u);
  EXPECT_EQ(done.keyReason, "start");
  EXPECT_EQ(done.scaledFor, VideoScaledFor::Encoders);
  EXPECT_EQ(other.decode(f).width, 64);
}

TEST(VideoStream, TheScaleForTheDrawingIsTheSmallestThatKeepsItsPixels) {
  EXPECT_EQ(VideoStream::scaleForDrawing(0.35, 1024, 1024), 0.375);
  EXPECT_EQ(VideoStream::scaleForDrawing(0.3, 1024, 1024), 0.375);
  EXPECT_EQ(VideoStream::scaleForDrawing(0.6, 1024, 1024), 0.75);
  EXPECT_EQ(VideoStream::scaleForDrawing(0.5, 1024, 1024), 0.5);
  EXPECT_EQ(VideoStream::scaleForDrawing(0.5 + 0.4 / 1024, 1024, 1024), 0.5) << "a drawing's side rounded up";
  EXPECT_EQ(VideoStream::scaleForDrawing(0.125, 1024, 1024), 0.25);
  EXPECT_EQ(VideoStream::scaleForDrawing(0.125, 512, 512), 0.5) << "never shorter than 256 pixels";
  EXPECT_EQ(VideoStream::scaleForDrawing(0.125, 1920, 480), 0.75) << "its shorter side";
  EXPECT_EQ(VideoStream::scaleForDrawing(0.2, 300, 300), 1) << "0.75 would be 225 pixels";
  EXPECT_EQ(VideoStream::scaleForDrawing(0.667, 96, 96), 1);
  EXPECT_EQ(VideoStream::scaleForDrawing(0, 1024, 1024), 1) << "not known";
  EXPECT_EQ(VideoStream::scaleForDrawing(1, 1024, 1024), 1);
}

// A crowd that leaves a stream's frames drawn smaller than the stream (the render ladder's choice without the
// stream's cap, the frame's `interactive.scale_wanted`) has the stream follow the drawing down, soon, and back up
// once the drawing has wanted more for a while; a drawing that wavers between two rungs settles on the larger.
TEST(VideoStream, AStreamFollowsItsDrawingDownAndBackUp) {
  VideoStream stream;
  image::FrameDecoder decoder;
  std::vector<std::pair<uint32_t, std::string>> shown;  // each frame's side, its key reason and why it is smaller
  const auto send = [&](double ms, double wanted) {
    proto::Frame f = rawFrame(512, int(ms));
    f.statsJson = nlohmann::json{{"interactive", {{"scale_wanted", wanted}}}}.dump();
    VideoFrameInput input;
    input.bitrateKbps = 4000, input.drawn = at(ms);
    const VideoEncoded done = stream.encode(f, input);
    const nlohmann::json stats = nlohmann::json::parse(f.statsJson);
    EXPECT_EQ(stats["interactive"]["scale_wanted"], wanted) << "the frame's statistics kept";
    const nlohmann::json& video = stats["video"];
    EXPECT_EQ(video["scale"].get<double>() * 512, double(f.width)) << f.statsJson;
    EXPECT_EQ(decoder.decode(f).width, int(f.width));
    const std::string why = video.value("scaled_for", "");
    EXPECT_EQ(why.empty(), done.scaledFor == VideoScaledFor::None);
    shown.emplace_back(f.width, (done.key ? done.keyReason : "-") + (why.empty() ? "" : " " + why));
  };
  send(0, 0);       // the first frame: no rate known, nothing wanted
  send(33, 0.42);   // drawn at 0.42 of 512²: a stream of 0.5 (256²) would keep its pixels
  send(200, 0.6);   // a rung larger: 0.75 wanted, still smaller
  send(350, 0.42);  // 317 ms of smaller calls: the least of them, 0.75
  send(383, 0.35);  // 0.375 would be 192 pixels: 0.5 wanted
  send(600, 0.42);
  send(700, 0.42);  // 317 ms: 0.5
  send(733, 1);     // the ladder would draw the whole scene: not yet
  send(1500, 0.6);  // 0.75: larger than the stream still
  send(2800, 1);    // 2067 ms of larger calls: the least of them, 0.75
  send(2833, 0.5);  // back down at once? no: not yet
  const std::vector<std::pair<uint32_t, std::string>> want = {
      {512, "start"},         {512, "-"},         {512, "-"},         {384, "size drawing"},
      {384, "- drawing"},     {384, "- drawing"}, {256, "size drawing"}, {256, "- drawing"},
      {256, "- drawing"},     {384, "size drawing"}, {384, "- drawing"}};
  EXPECT_EQ(shown, want);
  // Told not to (scheduler.stream_follows_drawing false), a stream keeps the size its link and encoders allow.
  VideoStream whole;
  for (double ms : {0.0, 33.0, 400.0, 800.0}) {
    proto::Frame f = rawFrame(512, int(ms));
    f.statsJson = R"({"interactive": {"scale_wanted": 0.3}})";
    VideoFrameInput input;
    input.bitrateKbps = 4000, input.drawn = at(ms), input.followDrawing = false;
    EXPECT_EQ(whole.encode(f, input).scaledFor, VideoScaledFor::None);
    EXPECT_EQ(f.width, 512u) << ms << " ms";
  }
}

TEST(VideoStream, NoStreamsEncoderHoldsMoreThanItsShareOfTheVideoMemory) {
  constexpr uint64_t MiB = 1 << 20;
  // VP9 at 4096² with 8 threads holds about 1.4 GiB (image::videoEncoderBytes); at 0.75, 3072², about 0.8.
  EXPECT_EQ(VideoStream::scaleForMemory(proto::Encoding::Vp9, 4096, 4096, 1024 * MiB, 8), 0.75);
  // VP8 at 1024², 46.5 MiB; at 0.75, 26.5; at 0.5, 12.
  EXPECT_EQ(VideoStream::scaleForMemory(proto::Encoding::Vp8, 1024, 1024, 16 * MiB, 2), 0.5);
  EXPECT_EQ(VideoStream::scaleForMemory(proto::Encoding::Vp8, 1024, 1024, 64 * MiB, 2), 1);
  EXPECT_EQ(VideoStream::scaleForMemory(proto::Encoding::Vp8, 1024, 1024, 1024, 2), 1)
      << "a budget no scale fits is left to the ledger";
  EXPECT_EQ(VideoStream::scaleForMemory(proto::Encoding::Vp8, 1024, 1024, 0, 2), 1);
  // A real stream on a budget of 16 MiB: its 512² VP8 encoder would hold 12 MiB, more than its quarter (4 MiB); at
  // 256², 3.4 MiB. It starts there at once, and says why.
  VideoMemory memory(16 * MiB);
  VideoStream stream(&memory);
  image::FrameDecoder decoder;
  for (int i = 0; i < 3; ++i) {
    proto::Frame f = rawFrame(512, i);
    VideoFrameInput input;
    input.bitrateKbps = 4000, input.drawn = at(33.0 * i);
    const VideoEncoded done = stream.encode(f, input);
    EXPECT_EQ(f.width, 256u) << "frame " << i;
    EXPECT_EQ(done.scaledFor, VideoScaledFor::Memory);
    EXPECT_EQ(done.key ? done.keyReason : "-", i == 0 ? "start" : "-");
    EXPECT_EQ(nlohmann::json::parse(f.statsJson)["video"]["scaled_for"], "memory") << f.statsJson;
    EXPECT_EQ(decoder.decode(f).width, 256);
  }
  EXPECT_LE(memory.bytes(), 4 * MiB);
}

}  // namespace
}  // namespace voxbrick::server
