// A session's video stream: key frame rules, the encoder's bitrate, the frame's statistics.
#include "server/VideoStream.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include <nlohmann/json.hpp>

namespace voxbrick::server {
namespace {

using Clock = std::chrono::steady_clock;

double msBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

double kbpsAt(int width, int height, double bitsPerPixel) { return double(width) * height * bitsPerPixel * 30 / 1000; }

}  // namespace

double VideoStream::startKbps(int width, int height) { return kbpsAt(width, height, 0.05); }
double VideoStream::capKbps(int width, int height) { return kbpsAt(width, height, 0.15); }

double VideoStream::scaleFor(double kbps, int width, int height) {
  const double pixels = std::max(1.0, double(width) * height);
  for (const double scale : kScales)
    if (kbps * 1000 / (30 * pixels * scale * scale) >= kMinBitsPerPixel) return scale;
  return kScales[std::size(kScales) - 1];
}

double VideoStream::settledScale(double wanted, Clock::time_point now) {
  if (wanted != mWanted) mWanted = wanted, mWantedSince = now;
  if (!mEncoder) return mScale = wanted;  // a stream's first frame starts at the link's scale
  if (mWanted == mScale) return mScale;
  const double waited = msBetween(mWantedSince, now);
  if (waited >= (mWanted < mScale ? kShrinkAfterMs : kGrowAfterMs)) mScale = mWanted;
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
  const int fullWidth = int(frame.width), fullHeight = int(frame.height);
  const double scale = settledScale(scaleFor(kbps, fullWidth, fullHeight), input.drawn);
  // (At the bitrate's floor of 1 kbit/s a side is only scaled to a quarter beyond 146 pixels: never below 36.)
  const int width = std::max(1, int(std::lround(fullWidth * scale)));
  const int height = std::max(1, int(std::lround(fullHeight * scale)));
  std::string why;
  if (!mEncoder || mEncoder->codec() != frame.encoding || mEncoder->width() != width || mEncoder->height() != height) {
    why = !mEncoder ? (mNoRoom ? "memory" : "start") : mEncoder->codec() != frame.encoding ? "codec" : "size";
    mBroken = false;
    mEncoder.reset();  // a failed construction leaves none
    image::VideoSettings settings;
    settings.width = width, settings.height = height, settings.bitrateKbps = kbps;
    settings.threads = image::videoThreadsFor(frame.encoding, width, height, int(std::thread::hardware_concurrency()));
    if (mMemory && !mMemory->reserve(*this, image::videoEncoderBytes(frame.encoding, width, height, settings.threads),
                                     start)) {
      mNoRoom = true;
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
  image::Image8 pixels{fullWidth, fullHeight, std::move(frame.payload)};
  if (width != fullWidth || height != fullHeight) {
    pixels = image::scaleImage(pixels, width, height);
    frame.width = uint32_t(width), frame.height = uint32_t(height);
  }
  image::VideoChunk chunk;
  try {
    chunk = mEncoder->encode(pixels, std::max(0.0, msBetween(mStart, input.drawn)), !why.empty());
  } catch (...) {
    mBroken = true;
    throw;
  }
  mBroken = false;
  if (mMemory) mMemory->used(*this, Clock::now());
  ++mFrames;
  if (chunk.key) ++mKeyFrames;
  frame.payload = std::move(chunk.bytes);
  nlohmann::json stats = nlohmann::json::parse(frame.statsJson, nullptr, false);
  if (!stats.is_object()) stats = nlohmann::json::object();
  VideoEncoded done{msBetween(start, Clock::now()), chunk.key, chunk.key ? (why.empty() ? "encoder" : why) : ""};
  stats["encode_ms"] = done.encodeMs;
  stats["encode_start_ms"] = msBetween(input.received, start);
  nlohmann::json video = {{"codec", proto::encodingName(frame.encoding)},
                          {"key", chunk.key},
                          {"stream_frame", mEncoder->frames() - 1},
                          {"bitrate_kbps", kbps},
                          {"scale", scale}};
  if (chunk.key) video["key_reason"] = done.keyReason;
  stats["video"] = std::move(video);
  frame.statsJson = stats.dump();
  return done;
}

}  // namespace voxbrick::server
