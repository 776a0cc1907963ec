// VP8 and VP9 streams through libvpx: what goes in comes out at once and near enough, key frames where asked, and a
// decoder given a broken stream says so instead of showing garbage.
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "image/Video.h"

namespace voxbrick::image {
namespace {

using proto::Encoding;

/// A smooth moving picture, like a volume rendering under a turning camera: a lit ball over a gradient.
Image8 picture(int width, int height, double t) {
  Image8 image{width, height, std::vector<uint8_t>(size_t(width) * size_t(height) * 4)};
  const double cx = width * (0.45 + 0.1 * std::sin(t)), cy = height * (0.5 + 0.1 * std::cos(t));
  const double r = 0.3 * std::min(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      uint8_t* p = image.rgba.data() + 4 * (size_t(y) * size_t(width) + size_t(x));
      const double d = std::hypot(x - cx, y - cy) / r;
      const double ball = d < 1 ? std::sqrt(1 - d * d) : 0;
      p[0] = uint8_t(std::lround(40 + 200 * ball));
      p[1] = uint8_t(std::lround(30 + 120 * ball + 40.0 * y / height));
      p[2] = uint8_t(std::lround(60 + 60.0 * x / width));
      p[3] = 255;
    }
  return image;
}

double psnr(const Image8& a, const Image8& b) { return compareImages(toImageF(a), toImageF(b)).psnr; }

class VideoCodecs : public ::testing::TestWithParam<Encoding> {};

TEST_P(VideoCodecs, AStreamRoundTripsFrameByFrameWithKeyFramesOnlyWhereAsked) {
  VideoSettings settings;
  settings.width = 161, settings.height = 97;  // odd sides: chroma planes round up
  settings.bitrateKbps = 1500;
  VideoEncoder encoder(GetParam(), settings);
  VideoDecoder decoder(GetParam());
  for (int i = 0; i < 12; ++i) {
    const Image8 in = picture(161, 97, 0.1 * i);
    const VideoChunk chunk = encoder.encode(in, 33.0 * i, i == 8);
    ASSERT_FALSE(chunk.bytes.empty());
    EXPECT_EQ(chunk.key, i == 0 || i == 8) << "frame " << i;
    const Image8 out = decoder.decode(chunk.bytes);  // each chunk decodes at once: nothing is held back
    ASSERT_EQ(out.width, 161);
    ASSERT_EQ(out.height, 97);
    EXPECT_EQ(out.rgba[3], 255);
    EXPECT_GT(psnr(in, out), 30.0) << "frame " << i;
  }
  EXPECT_EQ(encoder.frames(), 12u);
}

TEST_P(VideoCodecs, AThreadedStreamDecodesAsTheOneThreadStreamDoes) {
  // Four threads split a 1024x600 frame into token partitions (VP8) or tile columns (VP9); the decoder needs nothing
  // else, and the pictures are as near as one thread's. At a fixed speed: VP8's adaptive one follows the time each
  // encoder took, which on a busy machine differs between the two.
  VideoSettings settings;
  settings.width = 1024, settings.height = 600, settings.bitrateKbps = 3000;
  settings.adaptiveSpeed = false;
  VideoSettings threaded = settings;
  threaded.threads = 4;
  VideoEncoder one(GetParam(), settings), four(GetParam(), threaded);
  VideoDecoder fromOne(GetParam()), fromFour(GetParam());
  for (int i = 0; i < 6; ++i) {
    const Image8 in = picture(1024, 600, 0.1 * i);
    const Image8 a = fromOne.decode(one.encode(in, 33.0 * i).bytes);
    const Image8 b = fromFour.decode(four.encode(in, 33.0 * i).bytes);
    EXPECT_GT(psnr(in, a), 30.0) << "frame " << i;
    EXPECT_GT(psnr(in, b), psnr(in, a) - 1.5) << "frame " << i;
  }
}

/// `picture` with fine noise over it: detail that takes every bit a rate control gives.
Image8 detailed(int width, int height, double t) {
  Image8 image = picture(width, height, t);
  uint32_t state = 12345u + uint32_t(t * 1000);
  for (size_t i = 0; i < image.rgba.size(); ++i) {
    if (i % 4 == 3) continue;
    state = state * 1664525u + 1013904223u;
    image.rgba[i] = uint8_t(std::clamp(int(image.rgba[i]) + int(state >> 27) - 16, 0, 255));
  }
  return image;
}

TEST_P(VideoCodecs, TheBitrateSetsTheBytesAndCanChangeMidStream) {
  VideoSettings settings;
  settings.width = 256, settings.height = 256;
  settings.bitrateKbps = 4000;
  VideoEncoder steady(GetParam(), settings), lowered(GetParam(), settings);
  size_t steadyBytes = 0, loweredBytes = 0;
  for (int i = 0; i < 40; ++i) {
    if (i == 10) lowered.setBitrate(400);
    const Image8 frame = detailed(256, 256, 0.2 * i);
    const size_t a = steady.encode(frame, 33.0 * i).bytes.size(), b = lowered.encode(frame, 33.0 * i).bytes.size();
    if (i >= 25) steadyBytes += a, loweredBytes += b;
  }
  EXPECT_EQ(lowered.bitrateKbps(), 400);
  // 4000 kbit/s at 30 frames a second is about 16.7 kB a frame, 400 about 1.7 kB.
  EXPECT_GT(steadyBytes, 15u * 8000) << "the steady stream uses its bitrate";
  EXPECT_LT(loweredBytes * 4, steadyBytes) << "a tenth of the bitrate";
}

TEST_P(VideoCodecs, VariableBitrateAndNoAdaptiveQuantisationMakeStreamsOfTheirOwn) {
  // bench_video's alternatives to the server's settings: each a stream that decodes near its source, and each a
  // stream of other bytes than the server's (the setting reached libvpx). At a fixed speed, so that VP8's bytes differ
  // by the setting alone, not by a speed libvpx chose from the time each encoder took.
  VideoSettings server;
  server.width = 256, server.height = 256, server.bitrateKbps = 1500;
  server.adaptiveSpeed = false;
  VideoSettings vbr = server, noAq = server;
  vbr.constantBitrate = false;
  noAq.aqMode = 0;
  VideoEncoder a(GetParam(), server), b(GetParam(), vbr), c(GetParam(), noAq);
  VideoDecoder fromB(GetParam()), fromC(GetParam());
  size_t bytesA = 0, bytesB = 0, bytesC = 0;
  for (int i = 0; i < 20; ++i) {
    const Image8 frame = detailed(256, 256, 0.2 * i);
    const VideoChunk ca = a.encode(frame, 33.0 * i), cb = b.encode(frame, 33.0 * i), cc = c.encode(frame, 33.0 * i);
    bytesA += ca.bytes.size(), bytesB += cb.bytes.size(), bytesC += cc.bytes.size();
    EXPECT_GT(psnr(frame, fromB.decode(cb.bytes)), 25.0) << "vbr, frame " << i;
    EXPECT_GT(psnr(frame, fromC.decode(cc.bytes)), 25.0) << "aq 0, frame " << i;
  }
  EXPECT_NE(bytesA, bytesB) << "variable bitrate";
  if (GetParam() == Encoding::Vp9) {
    EXPECT_NE(bytesA, bytesC) << "no adaptive quantisation";
  }
}

/// What a stream's first 11 frames (its start: VideoSettings::startFrames) cost and show.
struct StartOf {
  double bytes = 0, psnr = 0;
};

/// Encodes 11 frames of `make` at 30 frames a second, after `keyAt` frames of it when that is above 0 (a key frame
/// forced mid-stream there), and returns the 11 frames' bytes and mean PSNR.
template <typename Make>
StartOf startOf(Encoding codec, const VideoSettings& settings, int keyAt, Make make) {
  VideoEncoder encoder(codec, settings);
  VideoDecoder decoder(codec);
  StartOf start;
  for (int i = 0; i < keyAt + 11; ++i) {
    const Image8 in = make(i);
    const VideoChunk chunk = encoder.encode(in, 1000.0 * i / 30, i == keyAt);
    const Image8 out = decoder.decode(chunk.bytes);
    if (i >= keyAt) start.bytes += double(chunk.bytes.size()), start.psnr += psnr(in, out) / 11;
  }
  return start;
}

/// The server's settings for a `side` x `side` stream at `kbps`, at a fixed speed (so that bytes differ by the
/// setting under test alone, not by a speed libvpx chose from the time each encoder took).
VideoSettings atFixedSpeed(int side, int kbps) {
  VideoSettings settings;
  settings.width = side, settings.height = side, settings.bitrateKbps = kbps;
  settings.adaptiveSpeed = false;
  return settings;
}

/// The start of a stream from frame 0 with `settings`, and the same without the start's cap.
template <typename Make>
std::pair<StartOf, StartOf> cappedAndNot(Encoding codec, const VideoSettings& settings, Make make) {
  VideoSettings uncapped = settings;
  uncapped.startFrames = 0;
  return {startOf(codec, settings, 0, make), startOf(codec, uncapped, 0, make)};
}

/// The bytes of frame `after` (frame 20, after a gap of `gapMs`) and the mean of the 10 frames before it, of a
/// stream of detailed frames at 30 frames a second.
std::pair<double, double> bytesAfterAGap(Encoding codec, const VideoSettings& settings, double gapMs) {
  VideoEncoder encoder(codec, settings);
  double before = 0, timeMs = 0;
  for (int i = 0; i < 20; ++i, timeMs += 1000.0 / 30) {
    const size_t bytes = encoder.encode(detailed(256, 256, 0.2 * i), timeMs).bytes.size();
    if (i >= 10) before += double(bytes) / 10;
  }
  const double after = double(encoder.encode(detailed(256, 256, 0.2 * 20), timeMs - 1000.0 / 30 + gapMs).bytes.size());
  return {after, before};
}

TEST_P(VideoCodecs, AFrameAfterAGapCostsWhatItsNeighboursDo) {
  // Half a second without a frame (a browser that stalled): the next frame gets no more bits than one at 30 frames a
  // second, where libvpx left alone gives it the half second's bits: a burst that queues on a slow link.
  VideoSettings settings = atFixedSpeed(256, 1500);
  const auto [after, before] = bytesAfterAGap(GetParam(), settings, 500);
  EXPECT_LT(after, 1.6 * before) << "after the gap " << after << " bytes, before it " << before << " a frame";
  settings.maxFrameMs = 0;  // real time: the burst this guards against
  const auto [burst, steady] = bytesAfterAGap(GetParam(), settings, 500);
  EXPECT_GT(burst, 2 * steady) << "after the gap " << burst << " bytes, before it " << steady << " a frame";
}

TEST_P(VideoCodecs, AStreamStartsSharpWithinItsShareOfTheBitrate) {
  // A smooth picture turning at 0.1 bits a pixel (800 kbit/s at 512x512): the rate control alone begins coarse and
  // under-spends; the start's cap spends the start's share, and shows it. A key frame forced later in the stream
  // is left to the rate control, which knows the picture by then.
  const VideoSettings settings = atFixedSpeed(512, 800);
  const auto make = [](int i) { return picture(512, 512, 0.05 * i); };
  const double share = 11 * 800.0 / 8 * 1000 / 30;  // bytes: 11 frames of 800 kbit/s at 30 a second
  const auto [capped, plain] = cappedAndNot(GetParam(), settings, make);
  EXPECT_GT(capped.psnr, plain.psnr + 1.0);
  EXPECT_LT(capped.bytes, share * 1.5);
  VideoEncoder encoder(GetParam(), settings);
  for (int i = 0; i < 40; ++i) {
    encoder.encode(make(i), 1000.0 * i / 30, i == 30);
    if (i < 11)
      EXPECT_LT(encoder.maxQuantizer(), kVideoMaxQuantizer) << "frame " << i;
    else
      EXPECT_EQ(encoder.maxQuantizer(), kVideoMaxQuantizer) << "frame " << i << (i == 30 ? ", a later key frame" : "");
  }
}

TEST_P(VideoCodecs, AStartDearerThanGuessedIsLeftToTheRateControl) {
  // Fine noise at 0.2 bits a pixel costs several times what the cap guessed for a rendering: the cap is lifted once
  // the start has spent its share and two frames more, so the start spends at most a few frames more than the
  // uncapped stream's (kept capped, VP8's took 7 frames' more and VP9's 20).
  const auto make = [](int i) { return detailed(256, 256, 0.2 * i); };
  const auto [capped, plain] = cappedAndNot(GetParam(), atFixedSpeed(256, 400), make);
  const double frameBytes = 400.0 / 8 * 1000 / 30;
  EXPECT_LT(capped.bytes, plain.bytes + 5 * frameBytes);
}

TEST_P(VideoCodecs, ADecoderRefusesWhatItCannotShow) {
  VideoSettings settings;
  settings.width = 64, settings.height = 48;
  VideoEncoder encoder(GetParam(), settings);
  const VideoChunk key = encoder.encode(picture(64, 48, 0), 0);
  const VideoChunk delta = encoder.encode(picture(64, 48, 0.3), 33);
  ASSERT_TRUE(key.key);
  ASSERT_FALSE(delta.key);
  {
    VideoDecoder decoder(GetParam());
    EXPECT_THROW(decoder.decode(delta.bytes), ImageFailure) << "a delta frame with no key frame before it";
  }
  {
    VideoDecoder decoder(GetParam());
    EXPECT_THROW(decoder.decode({}), ImageFailure);
    const std::vector<uint8_t> garbage(200, 0xA5);
    EXPECT_THROW(decoder.decode(garbage), ImageFailure);
    std::vector<uint8_t> cut(key.bytes.begin(), key.bytes.begin() + long(key.bytes.size() / 3));
    EXPECT_THROW(decoder.decode(cut), ImageFailure);
    // Then a whole key frame starts the stream again.
    EXPECT_EQ(decoder.decode(key.bytes).width, 64);
    EXPECT_EQ(decoder.decode(delta.bytes).height, 48);
  }
  EXPECT_THROW(encoder.encode(picture(32, 48, 0), 66), ImageFailure) << "a frame of another size";
}

INSTANTIATE_TEST_SUITE_P(Codecs, VideoCodecs, ::testing::Values(Encoding::Vp8, Encoding::Vp9),
                         [](const auto& codec) { return std::string(proto::encodingName(codec.param)); });

TEST(Video, ALargeVp9FrameGetsAThreadForEachQuarterMegapixel) {
  EXPECT_EQ(videoThreadsFor(Encoding::Vp9, 256, 256, 16), 1);
  EXPECT_EQ(videoThreadsFor(Encoding::Vp9, 512, 512, 16), 1);
  EXPECT_EQ(videoThreadsFor(Encoding::Vp9, 513, 512, 16), 2);
  EXPECT_EQ(videoThreadsFor(Encoding::Vp9, 1024, 1024, 16), 4);
  EXPECT_EQ(videoThreadsFor(Encoding::Vp9, 1920, 1080, 16), 8);
  EXPECT_EQ(videoThreadsFor(Encoding::Vp9, 4096, 4096, 64), 8);  // never more than 8
  EXPECT_EQ(videoThreadsFor(Encoding::Vp9, 1024, 1024, 2), 2);   // never more than the machine has
  EXPECT_EQ(videoThreadsFor(Encoding::Vp9, 1024, 1024, 0), 1);   // an unknown machine: one
}

TEST(Video, Vp8IsEncodedInOneThreadAndOnePartitionAtAnySize) {
  // Its threads spin while waiting for each other, in the encoder and in a browser's decoder of its partitions.
  for (const auto& [width, height] : {std::pair{512, 512}, {1024, 1024}, {1920, 1080}, {4096, 4096}})
    EXPECT_EQ(videoThreadsFor(Encoding::Vp8, width, height, 64), 1) << width << "x" << height;
}

TEST(Video, AStartsQuantizerCapFollowsTheBitsAPixel) {
  EXPECT_EQ(startQuantizerFor(0.09), 40);
  EXPECT_EQ(startQuantizerFor(0.18), 30);
  EXPECT_EQ(startQuantizerFor(0.045), 50);
  EXPECT_EQ(startQuantizerFor(0.02), kVideoMaxQuantizer) << "too few bits for any cap";
  EXPECT_EQ(startQuantizerFor(5.0), kVideoStartQuantizerFloor);
  EXPECT_EQ(startQuantizerFor(0.0), kVideoMaxQuantizer);
  EXPECT_EQ(startQuantizerFor(std::nan("")), kVideoMaxQuantizer);
  for (double bits = 0.01; bits < 1; bits *= 1.1) EXPECT_LE(startQuantizerFor(bits * 1.1), startQuantizerFor(bits));
}

TEST(Video, AnEncodersMemoryIsWhatTheServerCountsForIt) {
  // What malloc has given out for an encoder that has encoded ten frames, against videoEncoderBytes (which the
  // server's memory.video_mb counts): within 15 % either way, so that the budget holds what it says.
  const auto held = [] {
    const struct mallinfo2 info = mallinfo2();
    return double(info.uordblks) + double(info.hblkhd);
  };
  struct Case {
    Encoding codec;
    int width, height, threads;
    bool fullChroma = false;
  };
  for (const Case c : {Case{Encoding::Vp8, 512, 512, 1}, Case{Encoding::Vp8, 800, 600, 1},
                       Case{Encoding::Vp9, 512, 512, 1}, Case{Encoding::Vp9, 800, 600, 2},
                       Case{Encoding::Vp9, 512, 512, 1, true}, Case{Encoding::Vp9, 800, 600, 2, true}}) {
    VideoSettings settings;
    settings.width = c.width, settings.height = c.height, settings.threads = c.threads;
    settings.fullChroma = c.fullChroma;
    settings.bitrateKbps = 2000;
    std::vector<Image8> frames;
    for (int i = 0; i < 10; ++i) frames.push_back(picture(c.width, c.height, 0.2 * i));
    const double before = held();
    double measured = 0;
    {
      VideoEncoder encoder(c.codec, settings);
      for (int i = 0; i < 10; ++i) encoder.encode(frames[size_t(i)], 33.0 * i);
      measured = held() - before;
    }
    const double estimate = double(videoEncoderBytes(c.codec, c.width, c.height, c.threads, c.fullChroma));
    const std::string what = std::string(proto::encodingName(c.codec)) + (c.fullChroma ? " 4:4:4 " : " ") +
                             std::to_string(c.width) + "x" +
                             std::to_string(c.height) + ", " + std::to_string(c.threads) + " thread(s): held " +
                             std::to_string(measured / (1 << 20)) + " MiB, estimated " +
                             std::to_string(estimate / (1 << 20)) + " MiB";
    EXPECT_GT(measured, 0.85 * estimate) << what;
    EXPECT_LT(measured, 1.15 * estimate) << what;
    EXPECT_LT(held() - before, 0.05 * estimate) << what << "; not given back once the encoder is gone";
  }
  // A stream's memory grows with its pixels and threads.
  EXPECT_LT(videoEncoderBytes(Encoding::Vp9, 1024, 1024, 1), videoEncoderBytes(Encoding::Vp9, 1024, 1024, 4));
  EXPECT_LT(videoEncoderBytes(Encoding::Vp8, 1024, 1024, 1), videoEncoderBytes(Encoding::Vp9, 1024, 1024, 1));
  EXPECT_LT(videoEncoderBytes(Encoding::Vp9, 1024, 1024, 4), videoEncoderBytes(Encoding::Vp9, 1920, 1080, 4));
  EXPECT_LT(videoEncoderBytes(Encoding::Vp9, 1024, 1024, 2), videoEncoderBytes(Encoding::Vp9, 1024, 1024, 2, true));
}

/// Colour that changes from one pixel to the next at the same brightness: red and blue columns, a ball of green over
/// them, moving.
Image8 colourStripes(int width, int height, double t) {
  Image8 image = picture(width, height, t);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      uint8_t* p = image.rgba.data() + 4 * (size_t(y) * size_t(width) + size_t(x));
      if (p[0] > 60) continue;  // the ball stays
      const bool red = (x + int(t * 10)) % 2 == 0;
      p[0] = red ? 200 : 40, p[1] = 60, p[2] = red ? 40 : 255;
    }
  return image;
}

TEST(Video, Vp9InFourFourFourKeepsColourThatFourTwoZeroLoses) {
  // Odd sides: no plane is rounded up in 4:4:4.
  const int width = 161, height = 97;
  double db[2] = {0, 0};
  for (const bool full : {false, true}) {
    VideoSettings settings;
    settings.width = width, settings.height = height, settings.bitrateKbps = 4000;
    settings.fullChroma = full;
    VideoEncoder encoder(Encoding::Vp9, settings);
    EXPECT_EQ(encoder.fullChroma(), full);
    VideoDecoder decoder(Encoding::Vp9);  // the same decoder takes either
    for (int i = 0; i < 8; ++i) {
      const Image8 in = colourStripes(width, height, 0.1 * i);
      const VideoChunk chunk = encoder.encode(in, 33.0 * i);
      EXPECT_EQ(chunk.key, i == 0) << "frame " << i;
      const Image8 out = decoder.decode(chunk.bytes);
      ASSERT_EQ(out.width, width);
      ASSERT_EQ(out.height, height);
      db[full] += psnr(in, out) / 8;
    }
  }
  // Measured: 10.9 dB in 4:2:0 (the columns' colours averaged away), 41.6 in 4:4:4.
  EXPECT_GT(db[1], db[0] + 15) << "4:2:0 " << db[0] << " dB, 4:4:4 " << db[1] << " dB";
  EXPECT_GT(db[1], 35.0);
}

TEST(Video, OnlyVp9HasAFourFourFourStream) {
  VideoSettings settings;
  settings.width = 64, settings.height = 64, settings.fullChroma = true;
  try {
    VideoEncoder(Encoding::Vp8, settings);
    ADD_FAILURE() << "a VP8 stream in 4:4:4 was made";
  } catch (const ImageFailure& e) {
    EXPECT_NE(std::string(e.what()).find("4:4:4"), std::string::npos) << e.what();
  }
}

TEST(Video, OnlyVideoEncodingsAndSaneSettingsMakeAStream) {
  EXPECT_TRUE(isVideoEncoding(Encoding::Vp8));
  EXPECT_TRUE(isVideoEncoding(Encoding::Vp9));
  EXPECT_FALSE(isVideoEncoding(Encoding::Jpeg));
  VideoSettings settings;
  settings.width = 64, settings.height = 64;
  EXPECT_THROW(VideoEncoder(Encoding::Png, settings), ImageFailure);
  EXPECT_THROW(VideoDecoder(Encoding::Jpeg), ImageFailure);
  settings.width = 0;
  EXPECT_THROW(VideoEncoder(Encoding::Vp8, settings), ImageFailure);
  settings.width = 20000;
  EXPECT_THROW(VideoEncoder(Encoding::Vp8, settings), ImageFailure);
  settings.width = 64, settings.bitrateKbps = 0;
  EXPECT_THROW(VideoEncoder(Encoding::Vp8, settings), ImageFailure);
  settings.bitrateKbps = 1000, settings.startFrames = -1;
  EXPECT_THROW(VideoEncoder(Encoding::Vp8, settings), ImageFailure);
  settings.startFrames = 11, settings.aqMode = 4;
  try {
    VideoEncoder(Encoding::Vp9, settings);
    ADD_FAILURE() << "an adaptive quantisation mode outside 0..3 was taken";
  } catch (const ImageFailure& e) {
    EXPECT_NE(std::string(e.what()).find("adaptive quantisation mode 4"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace voxbrick::image
