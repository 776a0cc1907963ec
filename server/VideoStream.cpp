// A session's video stream: key frame rules, the encoder's bitrate, the frame's statistics.
#include "server/VideoStream.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include <nlohmann/json.hpp>

#include "render/core/Interactive.h"

namespace voxbrick::server {
namespace {

using Clock = std::chrono::steady_clock;

double msBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

/// The machine's cores, read once: std::thread::hardware_concurrency reads sysfs each time, and every frame asks.
int cores() {
  static const int kCores = int(std::thread::hardware_concurrency());
  return kCores;
}

double kbpsAt(int width, int height, double bitsPerPixel) { return double(width) * height * bitsPerPixel * 30 / 1000; }

}  // namespace

image::VideoSettings VideoStream::encoderSettings(proto::Encoding codec, int width, int height, double kbps,
                                                  bool fullChroma) {
  image::VideoSettings settings;
  settings.width = width, settings.height = height, settings.bitrateKbps = kbps;
  settings.threads = image::videoThreadsFor(codec, width, height, cores());
  settings.fullChroma = fullChroma;
  // A 4:4:4 stream without adaptive quantisation: 8 % fewer bytes for JPEG q85's PSNR on the MRI's turn, its worst
  // frame the same (in 4:2:0 2-4 %, and cyclic refresh stays there: bench/results/video/video-444.md).
  if (fullChroma) settings.aqMode = 0;
  return settings;
}

double VideoStream::startKbps(int width, int height) { return kbpsAt(width, height, 0.05); }
double VideoStream::capKbps(int width, int height) { return kbpsAt(width, height, 0.15); }

double VideoStream::scaleFor(double kbps, int width, int height) {
  const double pixels = std::max(1.0, double(width) * height);
  for (const double scale : kScales)
    if (kbps * 1000 / (30 * pixels * scale * scale) >= kMinBitsPerPixel) return scale;
  return kScales[std::size(kScales) - 1];
}

double VideoStream::costExponent(proto::Encoding codec) { return codec == proto::Encoding::Vp9 ? 0.6 : 0.75; }

double VideoStream::expectedMs(proto::Encoding codec, double msForAMegapixel, double megapixels) {
  return msForAMegapixel * std::pow(std::max(megapixels, 1e-6), costExponent(codec));
}

double VideoStream::scaleForEncoders(proto::Encoding codec, double msForAMegapixel, double shareMs, int width,
                                     int height, double current) {
  if (!(msForAMegapixel > 0) || !(shareMs > 0)) return 1;
  const double megapixels = std::max(1.0, double(width) * height) / 1e6;
  for (const double scale : kScales)
    if (expectedMs(codec, msForAMegapixel, megapixels * scale * scale) <=
        shareMs * (scale > current ? kGrowWithin : 1))
      return scale;
  return kScales[std::size(kScales) - 1];
}

double VideoStream::scaleForDrawing(double wantedScale, int width, int height) {
  if (!(wantedScale > 0) || wantedScale >= 1) return 1;
  const int shorter = std::min(width, height);
  double chosen = 1;
  // (The drawing's scale is its width's, rounded: a thousandth's leeway.)
  for (const double scale : kScales) {
    if (scale < wantedScale - 1e-3) break;
    if (render::scaledSide(shorter, scale) >= kDrawingFloorSide) chosen = scale;
  }
  return chosen;
}

double VideoStream::scaleForMemory(proto::Encoding codec, int width, int height, uint64_t limitBytes, int cores,
                                   bool fullChroma) {
  if (limitBytes == 0) return 1;
  for (const double scale : kScales) {
    const int w = render::scaledSide(width, scale), h = render::scaledSide(height, scale);
    if (image::videoEncoderBytes(codec, w, h, image::videoThreadsFor(codec, w, h, cores), fullChroma) <= limitBytes)
      return scale;
  }
  return 1;
}

double VideoStream::settledScale(double wanted, VideoScaledFor why, Clock::time_point now) {
  // A stream's first frame starts at the scale called for now.
  if (!mEncoder) {
    mScale = mWanted = wanted;
    mScaledFor = mScale == 1 ? VideoScaledFor::None : why;
    return mScale;
  }
  // A change is taken once every frame for the while has called for one the same way; to the least of them, so that
  // a call that wavers between two smaller scales (a drawing between two rungs) settles on the larger. mWanted is
  // mScale while no change is called for.
  const auto way = [this](double scale) { return scale < mScale ? -1 : scale > mScale ? 1 : 0; };
  const int change = way(wanted);
  if (change != way(mWanted)) {
    mWanted = wanted, mWantedFor = why, mWantedSince = now;
  } else if (change < 0 ? wanted > mWanted : wanted < mWanted) {
    mWanted = wanted, mWantedFor = why;
  }
  if (mWanted != mScale && msBetween(mWantedSince, now) >= (mWanted < mScale ? kShrinkAfterMs : kGrowAfterMs)) {
    mScale = mWanted, mScaledFor = mWantedFor;
  } else if (wanted == mScale) {
    mScaledFor = why;  // (while it waits for another scale, the reason it has this one stays)
  }
  if (mScale == 1) mScaledFor = VideoScaledFor::None;
  return mScale;
}

VideoStream::~VideoStream() {
  if (mMemory) mMemory->release(*this);
}

bool VideoStream::freeEncoder() {
  std::unique_lock lock(mMutex, std::try_to_lock);
  if (!lock.owns_lock()) return false;
  mEncoder.reset();
  mNoRoom = true;
  return true;
}

VideoEncoded VideoStream::encode(proto::Frame& frame, const VideoFrameInput& input) {
  std::lock_guard lock(mMutex);
  const auto start = Clock::now();
  const int kbps = int(std::lround(std::max(1.0, input.bitrateKbps)));
  const int fullWidth = input.sceneWidth > 0 ? input.sceneWidth : int(frame.width);
  const int fullHeight = input.sceneHeight > 0 ? input.sceneHeight : int(frame.height);
  const double forLink = scaleFor(kbps, fullWidth, fullHeight);
  // A stream that has not measured its own cost yet goes by the last one measured in its codec (a newcomer to a
  // crowd starts at the size the others were brought to, rather than with a key frame too large to encode in time).
  const bool fullChroma = input.fullChroma && frame.encoding == proto::Encoding::Vp9;
  const int costKind = VideoMemory::costKind(frame.encoding, fullChroma);
  const double cost = costKind == mCostKind ? mMsForAMegapixel
                      : mMemory             ? mMemory->msForAMegapixel(frame.encoding, fullChroma)
                                            : 0;
  const double forEncoders = scaleForEncoders(frame.encoding, cost, input.encodeShareMs, fullWidth, fullHeight, mScale);
  // The frame's own statistics say what its drawing wanted (render::InteractiveChoice::wantedScale).
  nlohmann::json stats = nlohmann::json::parse(frame.statsJson, nullptr, false);
  if (!stats.is_object()) stats = nlohmann::json::object();
  const auto drawing = stats.find("interactive");
  const double forDrawing =
      input.followDrawing && drawing != stats.end() && drawing->is_object()
          ? scaleForDrawing(drawing->value("scale_wanted", 0.0), fullWidth, fullHeight)
          : 1;
  const double wanted = std::min({forLink, forEncoders, forDrawing});
  double scale = settledScale(wanted,
                              wanted == 1             ? VideoScaledFor::None
                              : forEncoders == wanted ? VideoScaledFor::Encoders
                              : forLink == wanted     ? VideoScaledFor::Link
                                                      : VideoScaledFor::Drawing,
                              input.drawn);
  VideoScaledFor scaledFor = mScaledFor;
  if (mMemory) {
    const double forMemory = scaleForMemory(frame.encoding, fullWidth, fullHeight,
                                            uint64_t(kMemoryShare * double(mMemory->limit())), cores(), fullChroma);
    if (forMemory < scale) scale = forMemory, scaledFor = VideoScaledFor::Memory;
  }
  // (At the bitrate's floor of 1 kbit/s a side is only scaled to a quarter beyond 146 pixels: never below 36.)
  const int width = render::scaledSide(fullWidth, scale), height = render::scaledSide(fullHeight, scale);
  std::string why;
  // (VP9 in 4:4:4 is another codec to its decoder: a new stream.)
  const bool sameCodec = mEncoder && mEncoder->codec() == frame.encoding && mEncoder->fullChroma() == fullChroma;
  if (!sameCodec || mEncoder->width() != width || mEncoder->height() != height) {
    why = !mEncoder ? (mNoRoom ? "memory" : "start") : !sameCodec ? "codec" : "size";
    mBroken = false;
    mEncoder.reset();  // a failed construction leaves none
    const image::VideoSettings settings = encoderSettings(frame.encoding, width, height, kbps, fullChroma);
    if (mMemory &&
        !mMemory->reserve(
            *this, image::videoEncoderBytes(frame.encoding, width, height, settings.threads, settings.fullChroma),
            start)) {
      mNoRoom = true;
      mSentScale.store(1, std::memory_order_relaxed);  // its frames go as still JPEGs, drawn at the scene's size
      VideoEncoded none;
      none.noRoom = true;
      return none;
    }
    try {
      mEncoder = std::make_unique<image::VideoEncoder>(frame.encoding, settings);
    } catch (...) {
      if (mMemory) mMemory->release(*this);
      throw;
    }
    mNoRoom = false;
    mStart = input.drawn;
  } else if (mBroken) {
    why = "recovery";
  } else if (input.dataset != mDataset) {
    why = "dataset";
  } else if (input.keyframe) {
    why = "asked";
  }
  mDataset = input.dataset;
  mEncoder->setBitrate(kbps);
  image::Image8 pixels{int(frame.width), int(frame.height), std::move(frame.payload)};
  if (width != pixels.width || height != pixels.height) {
    pixels = image::scaleImage(pixels, width, height);
    frame.width = uint32_t(width), frame.height = uint32_t(height);
  }
  mSentScale.store(scale, std::memory_order_relaxed);
  image::VideoChunk chunk;
  try {
    chunk = mEncoder->encode(pixels, std::max(0.0, msBetween(mStart, input.drawn)), !why.empty());
  } catch (...) {
    mBroken = true;
    throw;
  }
  mBroken = false;
  const auto encoded = Clock::now();
  if (mMemory) mMemory->used(*this, encoded);
  if (!chunk.key) {
    // Key frames cost more than the inter frames a moving stream is made of: they would make it look slower.
    const double msForAMegapixel =
        msBetween(start, encoded) / expectedMs(frame.encoding, 1, double(width) * height / 1e6);
    const bool known = mCostKind == costKind && mMsForAMegapixel > 0;
    mMsForAMegapixel = known ? 0.75 * mMsForAMegapixel + 0.25 * msForAMegapixel : msForAMegapixel;
    mCostKind = costKind;
    if (mMemory) mMemory->measured(frame.encoding, fullChroma, mMsForAMegapixel);
  }
  ++mFrames;
  if (chunk.key) ++mKeyFrames;
  frame.payload = std::move(chunk.bytes);
  VideoEncoded done{msBetween(start, encoded), chunk.key, chunk.key ? (why.empty() ? "encoder" : why) : "", false,
                    scaledFor};
  stats["encode_ms"] = done.encodeMs;
  stats["encode_start_ms"] = msBetween(input.received, start);
  nlohmann::json video = {{"codec", proto::encodingName(frame.encoding)},
                          {"key", chunk.key},
                          {"stream_frame", mEncoder->frames() - 1},
                          {"bitrate_kbps", kbps},
                          {"scale", scale}};
  if (frame.encoding == proto::Encoding::Vp9) video["chroma"] = fullChroma ? "4:4:4" : "4:2:0";
  if (chunk.key) video["key_reason"] = done.keyReason;
  if (scaledFor != VideoScaledFor::None) video["scaled_for"] = common::nameOf(scaledFor);
  stats["video"] = std::move(video);
  frame.statsJson = stats.dump();
  return done;
}

}  // namespace voxbrick::server
