// One session's video stream: its moving frames (provisional Frames in vp8 or vp9) encoded in order by one encoder,
// with a key frame where a decoder could not go on from the frame before (PROTOCOL.md, Session 11): the stream's
// first frame, a new codec or size, a new dataset, and a scene that asks for one (`keyframe`). Encoded off the render
// threads and off the I/O threads, one frame at a time (its Connection sees to that). Its encoder's memory is counted
// in the server's VideoMemory: freed for another stream's while this one rests; a frame that finds no room is left
// to its Connection, which sends it as a still JPEG.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "image/Video.h"
#include "proto/Messages.h"
#include "server/VideoMemory.h"
#include "server/VideoScaledFor.h"

namespace voxbrick::server {

/// What a frame's encoding needs besides its pixels.
struct VideoFrameInput {
  const void* dataset = nullptr;  ///< the frame's dataset (identity only): a new one starts the stream again
  bool keyframe = false;          ///< the scene asked for a key frame
  /// The client decodes VP9 in 4:4:4 (the scene's `accepts_vp9_444`): a vp9 stream goes in VP9's profile 1
  /// (image::VideoSettings::fullChroma; a vp8 one as ever); a change either way starts it again (`key_reason` `codec`).
  bool fullChroma = false;
  double bitrateKbps = 0;         ///< the target the session's link allows (LinkPacer::videoKbps)
  std::chrono::steady_clock::time_point drawn;     ///< when its pixels were ready (the stream's timestamps)
  std::chrono::steady_clock::time_point received;  ///< when its Render arrived (for the frame's encode_start_ms)
  /// The encoder time the crowd leaves the frame, ms: the encoder threads' share of each stream moving at
  /// scheduler.interactive_fps (frameShareMs; Connection). 0: no limit.
  double encodeShareMs = 0;
  /// The stream may follow the frame's drawing down (scaleForDrawing; scheduler.stream_follows_drawing).
  bool followDrawing = true;
  /// The scene's size, which the frame may have been drawn smaller than (at the stream's scale, RenderJob's
  /// outputScale); 0: the frame's own.
  int sceneWidth = 0, sceneHeight = 0;
};

/// What one encode did, for the server's counters.
struct VideoEncoded {
  double encodeMs = 0;    ///< the encoding alone (the frame's `encode_ms`)
  bool key = false;       ///< a key frame
  std::string keyReason;  ///< a key frame's reason (PROTOCOL.md: start, codec, size, dataset, asked, recovery, memory,
                          ///< encoder)
  /// Nothing was encoded: the stream needed a new encoder and the server's video memory had no room for it. The
  /// frame is left as it came (its RGBA8 pixels), to go as a still JPEG (Connection).
  bool noRoom = false;
  VideoScaledFor scaledFor = VideoScaledFor::None;  ///< why the frame went smaller than its scene, if it did
};

class VideoStream final : public VideoMemory::Holder {
 public:
  /// `memory`: the server's ledger of encoder memory, which outlives the stream (null: none, no limit).
  explicit VideoStream(VideoMemory* memory = nullptr) : mMemory(memory) {}
  ~VideoStream();
  VideoStream(const VideoStream&) = delete;
  VideoStream& operator=(const VideoStream&) = delete;

  /// The settings a stream's encoder is made with: the size, the bitrate, image::videoThreadsFor's threads, and
  /// `fullChroma` (a vp9 stream in 4:4:4, encoded without adaptive quantisation; in 4:2:0 with image's cyclic refresh).
  static image::VideoSettings encoderSettings(proto::Encoding codec, int width, int height, double kbps,
                                              bool fullChroma);
  /// The bitrate a stream of `width` x `height` starts at, and the most it is given (kbit/s): about 0.05 and 0.15
  /// bits a pixel at 30 frames a second (bench/results/video: the MRI at 1024² is then above 40 dB).
  static double startKbps(int width, int height);
  static double capKbps(int width, int height);

  /// The stream sizes a frame may be sent at, as fractions of its side, largest first.
  static constexpr double kScales[] = {1, 0.75, 0.5, 0.375, 0.25};
  /// The fewest bits a pixel (at 30 frames a second) a stream is given before it is made smaller: below about 0.02
  /// libvpx cannot hold the rate at all (its coarsest quantiser still spends more), and at equal bytes a smaller
  /// stream scaled back up loses to the full one above it (bench/results/video/video-scale.md).
  static constexpr double kMinBitsPerPixel = 0.025;
  /// The largest of kScales at which `kbps` gives a `width` x `height` frame kMinBitsPerPixel; the smallest if none.
  static double scaleFor(double kbps, int width, int height);
  /// The power of a frame's megapixels its encoding time grows by in `codec` (vp8 or vp9): a frame of half the
  /// sides takes more than a quarter of the time (fitted on the MRI at 1024² to 256², one thread, a bitrate the
  /// same at every size: 0.77 for VP8, 0.61 for VP9, here 0.75 and 0.6; bench/results/video/encode-cost.md).
  static double costExponent(proto::Encoding codec);
  /// What a frame of `megapixels` in `codec` is expected to take, ms, at `msForAMegapixel` (the time of a frame of
  /// one megapixel): msForAMegapixel * megapixels ^ costExponent(codec).
  static double expectedMs(proto::Encoding codec, double msForAMegapixel, double megapixels);
  /// The largest of kScales at which a `width` x `height` frame in `codec` is expected to encode within `shareMs`
  /// (expectedMs, at the stream's measured `msForAMegapixel`); one larger than `current` only within kGrowWithin of
  /// it (so that a stream grown back is not at once too slow again). 1 when the cost or the share is unknown (0);
  /// the smallest if none fits. The crowd's ladder reaching the encoders: with more streams moving than the encoder
  /// threads keep at scheduler.interactive_fps, frames are sent smaller instead of later.
  static double scaleForEncoders(proto::Encoding codec, double msForAMegapixel, double shareMs, int width, int height,
                                 double current);
  static constexpr double kGrowWithin = 0.75;
  /// The shortest side a stream is made smaller to for its drawing (scaleForDrawing): below it an encoding costs
  /// little (VP9 at 256², 2.7 ms on one thread; bench/results/video/encode-cost.md), while each change of size is a
  /// key frame.
  static constexpr int kDrawingFloorSide = 256;
  /// The smallest of kScales no smaller than `wantedScale`, the scale a crowd leaves a moving frame's drawing
  /// (render::InteractiveChoice::wantedScale, the frame's `interactive.scale_wanted`: what the interactive ladder
  /// draws at, the stream's own size aside), whose shorter side keeps kDrawingFloorSide pixels; 1 where none is
  /// smaller, or `wantedScale` is unknown (0). A frame drawn at a fifth of the scene's sides is not scaled up to the
  /// full size to be encoded there: the stream follows the drawing down (`video.scaled_for` `drawing`), and back up
  /// when the drawing would be larger than the stream. As the wanted scale is the ladder's choice without the
  /// stream's cap, a stream made smaller does not make its drawing look cheap enough to grow it again.
  static double scaleForDrawing(double wantedScale, int width, int height);
  /// The most of the server's video memory (memory.video_mb) one stream's encoder may hold: a quarter, so that a
  /// stream of any size leaves room for three more (a client asking VP9 at 4096² would hold 1.4 GiB of the default
  /// 4 GiB, and three such left a fourth session JPEG).
  static constexpr double kMemoryShare = 0.25;
  /// The largest of kScales at which an encoder of `codec` for a `width` x `height` frame, with the threads
  /// image::videoThreadsFor gives it on `cores` cores (in 4:4:4 with `fullChroma`), holds at most `limitBytes`
  /// (image::videoEncoderBytes). 1 where even the smallest does not (a budget that small is left to the ledger,
  /// stream by stream) or `limitBytes` is 0.
  /// Taken at once, without the hysteresis below: it is a limit, not a measure.
  static double scaleForMemory(proto::Encoding codec, int width, int height, uint64_t limitBytes, int cores,
                               bool fullChroma = false);
  /// How long the link (or the encoders' share, or the drawing) must call for another scale before the stream changes
  /// to it (each change is a key frame): a smaller one soon, a larger one only once it has held up a while. Every
  /// frame of the while must call for a change the same way; the stream then takes the least of those changes.
  static constexpr double kShrinkAfterMs = 300, kGrowAfterMs = 2000;

  /// Encodes `frame` (a Frame in vp8 or vp9 whose payload is its RGBA8 pixels, as renderReply leaves it) as the
  /// stream's next frame: the payload becomes the compressed frame and its statistics gain `encode_ms` and `video`
  /// (PROTOCOL.md, Frame statistics). Where the bitrate is too low for the frame's size (scaleFor), its encoding
  /// would take more than its share of the encoders (scaleForEncoders), its drawing was made smaller than the stream
  /// by the crowd (scaleForDrawing), or its encoder would hold more than its share of the video memory
  /// (scaleForMemory), the frame is scaled down first and its width and height become the
  /// stream's (the client shows it at the scene's size; `video.scaled_for` says why). A frame that comes at another
  /// size than the stream's (drawn at scale() before the stream changed its size) is scaled to it.
  /// Where the stream needs a new encoder and the server's video memory has no room for it, the frame is left as it
  /// came and the returned VideoEncoded says `noRoom`. Throws image::ImageFailure; the next frame is then a key
  /// frame.
  VideoEncoded encode(proto::Frame& frame, const VideoFrameInput& input);

  /// VideoMemory::Holder: frees the encoder unless a frame is being encoded (the next frame is then a key frame,
  /// `key_reason` `memory`).
  bool freeEncoder() override;

  /// The scale of the scene's sides its last frame was sent at (1 before any): what its next frame is drawn at
  /// (RenderJob::outputScale). Read from any thread.
  double scale() const { return mSentScale.load(std::memory_order_relaxed); }

  /// Frames encoded, and streams begun (key frames).
  uint64_t frames() const { return mFrames; }
  uint64_t keyFrames() const { return mKeyFrames; }

 private:
  /// The scale the stream is sent at, given the one the link and the encoders call for now and `why` (the hysteresis
  /// above); sets mScaledFor, the reason for the scale it is sent at.
  double settledScale(double wanted, VideoScaledFor why, std::chrono::steady_clock::time_point now);

  VideoMemory* const mMemory;
  std::mutex mMutex;  ///< held while a frame is encoded: freeEncoder leaves the encoder of one being encoded
  std::unique_ptr<image::VideoEncoder> mEncoder;
  bool mNoRoom = false;  ///< the encoder was freed for another stream's, or none could be made: the next key's reason
  double mScale = 1;
  /// The least change of scale called for by every frame since mWantedSince (settledScale), and its reason; mScale
  /// while none is called for.
  double mWanted = 1;
  VideoScaledFor mWantedFor = VideoScaledFor::None;
  std::atomic<double> mSentScale = 1;  ///< mScale, or the memory's smaller one, as the last frame was sent
  VideoScaledFor mScaledFor = VideoScaledFor::None;
  /// The stream's inter frames' encoding time in its kind mCostKind (VideoMemory::costKind; -1: none encoded yet),
  /// as the ms of a frame of one megapixel (expectedMs), smoothed.
  double mMsForAMegapixel = 0;
  int mCostKind = -1;
  std::chrono::steady_clock::time_point mWantedSince;
  const void* mDataset = nullptr;
  std::chrono::steady_clock::time_point mStart;
  uint64_t mFrames = 0, mKeyFrames = 0;
  bool mBroken = false;  ///< the last encoding failed: start again with a key frame
};

}  // namespace voxbrick::server
