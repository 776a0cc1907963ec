// Video frames: a stream of 8-bit RGBA images as VP8 or VP9 (libvpx), one compressed frame each, with no frame held
// back (no lag, no B-frames: each image put in comes out at once), and back. The protocol's vp8 and vp9 encodings
// (proto::Encoding) carry these frames; RGBA to I420 (or VP9's I444) and back is libyuv's (BT.601, limited range, as
// browsers decode VP8 and VP9 that say nothing else).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "image/FrameImage.h"
#include "image/Image.h"
#include "proto/Messages.h"

namespace voxbrick::image {

/// Whether `encoding` is a video codec of this module (vp8, vp9).
bool isVideoEncoding(proto::Encoding encoding);

/// How a stream is encoded. The defaults are the realtime settings measured in bench/results/video.
struct VideoSettings {
  int width = 0, height = 0;  ///< the coded size, each in 1 .. 16383
  int bitrateKbps = 2000;     ///< the rate control's target, >= 1
  /// libvpx's realtime speed (VP8: 4..16, VP9: 5..9; higher is faster and coarser). VP8 with `adaptiveSpeed` takes
  /// it as a share of the frame interval instead: libvpx then picks each frame's speed from how long the last ones
  /// took to encode, within (16 - speed) / 16 of the interval, so a busy machine gets coarser frames, not later ones.
  int speed = 8;
  bool adaptiveSpeed = true;  ///< VP8 only (VP9's speed is always as set); false: every frame at `speed`
  int threads = 1;            ///< encoder threads (VP8 splits a frame into token partitions, VP9 into tile columns)
  /// The rate control: constant bitrate (each frame near its share of the target, so frames never queue on a link of
  /// that rate), or variable (libvpx's VBR: the target is a mean, frames vary with the picture). bench_video compares
  /// them; the server streams at constant bitrate.
  bool constantBitrate = true;
  int aqMode = 3;  ///< VP9's adaptive quantisation, 0..3 (0 none, 3 cyclic refresh as WebRTC's); VP8 has none
  /// VP9 only: colour at every pixel (4:4:4, VP9's profile 1; WebCodecs codec "vp09.01.41.08.03") instead of one
  /// colour sample a 2x2 block (4:2:0, profile 0). On the MRI's 1024² turn 0.6-1.0 dB more PSNR at equal bytes, and
  /// at JPEG q85's PSNR 0.24 of JPEG's bytes where 4:2:0 takes 0.41, for 1.2-1.6 times the encoding time and 1.3 times
  /// the encoder's memory (bench/results/video/video-444.md). A decoder takes either (VideoDecoder, browsers' software
  /// VP9).
  bool fullChroma = false;
  /// A stream's start: its first frames, `startFrames` of them (a third of a second at 30 frames a second; 0: none).
  /// libvpx's one-pass realtime rate control begins a stream from a coarse guess and takes about ten frames to find
  /// the picture's quantizer, so without help a stream began blurred (bench/results/video/video-start.md). The
  /// start's quantizer is capped instead: at startQuantizerFor the bits a pixel the bitrate gives a frame, then 4
  /// steps finer after each frame while the start has spent less than its share of the bitrate, and not at all once it
  /// has spent more than its share and two frames' (a picture dearer than the guess: the rate control takes over).
  /// A key frame later in the stream gets no cap: by then the rate control knows the picture.
  int startFrames = 11;
  /// The most time one frame's bits are reckoned over, in ms (0: no limit). libvpx's rate control gives a frame the
  /// bitrate times the time since the frame before, so a frame after a gap (a browser that stalled, frames skipped
  /// on a slow link) came as a burst: up to 100 kB at 4.7 Mbit/s where its neighbours took 20, queueing on the link
  /// and leaving a longer gap before the next one. Capped at 30 frames a second's share, frames after gaps cost
  /// what others do (bench/results/video/video-gaps.md).
  double maxFrameMs = 1000.0 / 30;
};

/// libvpx's quantizers (0..63) a stream may use: the rate control's range, and the finest a start's cap goes.
inline constexpr int kVideoMinQuantizer = 2, kVideoMaxQuantizer = 56, kVideoStartQuantizerFloor = 24;

/// The cap on a stream's first quantizer when the bitrate gives a frame `bitsPerPixel` (at 30 frames a second): 40 at
/// 0.09 bits a pixel, 10 steps finer for each doubling, within kVideoStartQuantizerFloor..kVideoMaxQuantizer (no
/// cap). Fitted to what the MRI drag's start cost at 512x512, whose pixels cost more than at 1024x1024, so that
/// a start stays near its share of the bitrate.
int startQuantizerFor(double bitsPerPixel);

/// The encoder threads a VP9 frame of this size is worth: one for each 512x512 pixels or part of them (a quarter of
/// a 1024x1024 frame each), at most `available` and at most 8. Fewer threads would leave a large frame's encoding the
/// longest step of a dragged frame; more share too little work to pay for their start. VP8 gets one at any size:
/// libvpx's VP8 threads wait for each other's rows by spinning, and a frame of several token partitions (one a
/// thread) is decoded in threads that do so too, so on a machine whose cores are busy (a server rendering, a viewer's
/// laptop) a 1024x1024 frame took 4 to 7 times as long to encode as in one thread, and Chromium's decoder held
/// frames back for seconds (bench/results/video/video-vp8-threads.md); VP9's tiles showed neither.
int videoThreadsFor(proto::Encoding codec, int width, int height, int available);

/// The memory an encoder of `codec` at `width` x `height` with `threads` threads holds once it has encoded its first
/// frames: what malloc gave it, fitted to bench_stream_start's measurements (bench/results/video/encoder-memory.md);
/// `fullChroma`: a VP9 encoder in 4:4:4 (VideoSettings::fullChroma).
uint64_t videoEncoderBytes(proto::Encoding codec, int width, int height, int threads, bool fullChroma = false);

/// One compressed frame: what a decoder of the codec takes as one chunk (WebCodecs' EncodedVideoChunk).
struct VideoChunk {
  std::vector<uint8_t> bytes;
  bool key = false;  ///< decodable on its own: a stream's first frame, and any forced one
};

/// A VP8 or VP9 encoder for one stream of frames of one size. Not thread-safe: one caller at a time.
class VideoEncoder {
 public:
  /// Throws ImageFailure naming the problem (an encoding that is no video codec, a size or bitrate out of range,
  /// libvpx refusing its configuration).
  VideoEncoder(proto::Encoding codec, const VideoSettings& settings);
  ~VideoEncoder();
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;

  /// Encodes `image` (the stream's size; throws ImageFailure otherwise) shown at `timeMs` after the stream began
  /// (non-decreasing: the rate control spreads its bits over the time between frames, each gap counted up to
  /// VideoSettings::maxFrameMs). The first frame, and any with `key`, is a key frame; the others refer to the frames
  /// before them, so each chunk must reach the decoder, in order.
  VideoChunk encode(const Image8& image, double timeMs, bool key = false);
  /// Changes the target bitrate from the next frame on (no key frame).
  void setBitrate(int kbps);

  proto::Encoding codec() const { return mCodec; }
  int width() const { return mSettings.width; }
  int height() const { return mSettings.height; }
  int bitrateKbps() const { return mSettings.bitrateKbps; }
  bool fullChroma() const { return mSettings.fullChroma; }
  /// Frames encoded so far.
  uint64_t frames() const { return mFrames; }
  /// The highest quantizer the rate control could use for the latest frame: below kVideoMaxQuantizer in a start's
  /// frames that were capped (VideoSettings::startFrames).
  int maxQuantizer() const;

 private:
  struct Codec;
  proto::Encoding mCodec;
  VideoSettings mSettings;
  std::unique_ptr<Codec> mCodecState;
  int64_t mLastPts = -1;
  double mLastTimeMs = 0, mStreamMs = 0;  ///< the last frame's `timeMs`, and its time in the stream (gaps capped)
  uint64_t mFrames = 0;
  /// The stream's start: its first frame's time, the bytes and count of its frames so far (up to startFrames), and
  /// its quantizer cap.
  struct Start {
    int64_t pts = 0;
    double bytes = 0;
    int frames = 0, quantizer = kVideoMaxQuantizer;
  } mStart;
};

/// A VP8 or VP9 decoder for one stream: chunks in the order they were encoded, the first a key frame.
class VideoDecoder {
 public:
  /// Throws ImageFailure for an encoding that is no video codec.
  explicit VideoDecoder(proto::Encoding codec);
  ~VideoDecoder();
  VideoDecoder(const VideoDecoder&) = delete;
  VideoDecoder& operator=(const VideoDecoder&) = delete;

  /// The image of the next chunk (alpha 255). Throws ImageFailure naming the problem when the chunk does not decode
  /// (damaged, or a delta frame with no key frame before it), or decodes to a size above kMaxSide a side; the
  /// decoder then wants a key frame.
  Image8 decode(std::span<const uint8_t> chunk);
  proto::Encoding codec() const { return mCodec; }

  static constexpr int kMaxSide = 16383;

 private:
  struct Codec;
  proto::Encoding mCodec;
  std::unique_ptr<Codec> mCodecState;
};

/// Decodes one session's Frames, whatever their encoding: a still alone (decodeFrameImage), a video frame in its
/// stream (a VideoDecoder kept from frame to frame; the Frames must be given in the order they arrived, every one).
class FrameDecoder {
 public:
  /// The frame's image (alpha 255 for jpeg and video). Throws ImageFailure naming the problem, as decodeFrameImage and
  /// VideoDecoder::decode do, and when a video frame decodes to another size than the Frame says; after a video
  /// frame fails, the stream goes on only from a key frame (a client asks one with the scene's `keyframe`).
  Image8 decode(const proto::Frame& frame);
  /// Video frames decoded so far.
  uint64_t videoFrames() const { return mVideoFrames; }

 private:
  std::unique_ptr<VideoDecoder> mVideo;
  uint64_t mVideoFrames = 0;
};

}  // namespace voxbrick::image
