// One session's video stream: its moving frames (provisional Frames in vp8 or vp9) encoded in order by one encoder,
// with a key frame where a decoder could not go on from the frame before (PROTOCOL.md, Session 11): the stream's
// first frame, a new codec or size, a new dataset, and a scene that asks for one (`keyframe`). Encoded off the render
// threads and off the I/O threads, one frame at a time (its Connection sees to that).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "image/Video.h"
#include "proto/Messages.h"

namespace voxbrick::server {

/// What a frame's encoding needs besides its pixels.
struct VideoFrameInput {
  const void* dataset = nullptr;  ///< the frame's dataset (identity only): a new one starts the stream again
  bool keyframe = false;          ///< the scene asked for a key frame
  double bitrateKbps = 0;         ///< the target the session's link allows (LinkPacer::videoKbps)
  std::chrono::steady_clock::time_point drawn;  ///< when its pixels were ready (the stream's timestamps)
};

/// What one encode did, for the server's counters.
struct VideoEncoded {
  double encodeMs = 0;    ///< the encoding alone (the frame's `encode_ms`)
  bool key = false;       ///< a key frame
  std::string keyReason;  ///< a key frame's reason (PROTOCOL.md: start, codec, size, dataset, asked, recovery, encoder)
};

class VideoStream {
 public:
  /// The bitrate a stream of `width` x `height` starts at, and the most it is given (kbit/s): about 0.05 and 0.15
  /// bits a pixel at 30 frames a second (bench/results/video: the MRI at 1024² is then above 40 dB).
  static double startKbps(int width, int height);
  static double capKbps(int width, int height);

  /// Encodes `frame` (a Frame in vp8 or vp9 whose payload is its RGBA8 pixels, as renderReply leaves it) as the
  /// stream's next frame: the payload becomes the compressed frame and its statistics gain `encode_ms` and `video`
  /// (PROTOCOL.md, Frame statistics). Throws image::ImageFailure; the next frame is then a key frame.
  VideoEncoded encode(proto::Frame& frame, const VideoFrameInput& input);

  /// Frames encoded, and streams begun (key frames).
  uint64_t frames() const { return mFrames; }
  uint64_t keyFrames() const { return mKeyFrames; }

 private:
  std::unique_ptr<image::VideoEncoder> mEncoder;
  const void* mDataset = nullptr;
  std::chrono::steady_clock::time_point mStart;
  uint64_t mFrames = 0, mKeyFrames = 0;
  bool mBroken = false;  ///< the last encoding failed: start again with a key frame
};

}  // namespace voxbrick::server
