// The memory of every session's video encoder together (memory.video_mb), and what the encoders cost in time. A
// libvpx encoder holds 46 (VP8) to 80 (VP9) bytes a pixel of its stream and more for each thread
// (image::videoEncoderBytes): a VP9 stream at 1920x1080 holds about 220 MiB, and a crowd of such streams would take
// the server's memory without bound. So each stream asks this ledger for its encoder's bytes before it makes one.
// Past the budget, the encoders of streams that have rested longest (no frame for kIdleMs or more) are freed to make
// room, least recently used first; such a stream starts again with a key frame (key_reason `memory`) when its camera
// moves again. Where even that leaves too little room, the stream's frame travels as JPEG instead (PROTOCOL.md,
// Session 11), and the stream asks again at its next. The streams moving, and the time their frames take to encode,
// size each stream's share of the encoder threads (VideoStream::scaleForEncoders).
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <unordered_map>

#include "proto/Messages.h"

namespace voxbrick::server {

class VideoMemory {
 public:
  using Clock = std::chrono::steady_clock;
  /// How long a stream must have had no frame before its encoder may be freed for another's: five times the interval
  /// of the slowest drag the server keeps up (scheduler.min_interactive_fps, 5 a second), so a moving camera's stream
  /// is never one.
  static constexpr std::chrono::milliseconds kIdleMs{1000};

  /// What holds an encoder counted here (a VideoStream).
  class Holder {
   public:
    /// Frees the encoder unless it is encoding now; returns whether it did. Called with the ledger's lock held: it
    /// must not call back into the ledger.
    virtual bool freeEncoder() = 0;

   protected:
    ~Holder() = default;
  };

  explicit VideoMemory(uint64_t limitBytes) : mLimit(limitBytes) {}

  /// Counts `bytes` for `holder`'s new encoder (what it held before is no longer counted: it has freed it). True when
  /// they fit, once idle holders' encoders have been freed if need be (those with no frame since `now` - kIdleMs,
  /// the least recently used first, never `holder`); false when they do not, and `holder` then holds nothing here.
  bool reserve(Holder& holder, uint64_t bytes, Clock::time_point now);
  /// `holder` encoded a frame at `now`.
  void used(Holder& holder, Clock::time_point now);
  /// `holder` freed its encoder (or is gone): its bytes are counted no more.
  void release(Holder& holder);

  uint64_t limit() const { return mLimit; }
  /// The bytes counted now, the most they have been, and the encoders they are for.
  uint64_t bytes() const;
  uint64_t peakBytes() const;
  size_t encoders() const;
  /// The streams that encoded a frame within kIdleMs of `now`: those whose cameras move, which share the encoder
  /// threads (Connection: the encoder time a moving frame may take).
  size_t moving(Clock::time_point now) const;
  /// What a stream's inter frames in `codec` (vp8 or vp9; VP9 in 4:4:4 with `fullChroma`) cost to encode, as the ms
  /// of a frame of one megapixel (VideoStream::expectedMs), as a stream measured it last; 0 before any. A stream's
  /// first frame goes by it.
  double msForAMegapixel(proto::Encoding codec, bool fullChroma = false) const;
  /// Streams whose encoding costs are told apart: 0 vp8, 1 vp9, 2 vp9 in 4:4:4.
  static int costKind(proto::Encoding codec, bool fullChroma) {
    return codec != proto::Encoding::Vp9 ? 0 : fullChroma ? 2 : 1;
  }
  void measured(proto::Encoding codec, bool fullChroma, double msForAMegapixel);
  /// Encoders freed to make room for another's, and frames sent as JPEG because none could be freed.
  uint64_t freed() const;
  uint64_t refused() const;

 private:
  struct Entry {
    uint64_t bytes = 0;
    Clock::time_point lastUse;
  };

  const uint64_t mLimit;
  mutable std::mutex mMutex;
  std::unordered_map<Holder*, Entry> mEntries;
  uint64_t mBytes = 0, mPeak = 0, mFreed = 0, mRefused = 0;
  std::array<double, 3> mMsForAMegapixel{};  ///< by costKind: vp8, vp9, vp9 in 4:4:4
};

}  // namespace voxbrick::server
