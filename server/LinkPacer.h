// One session's link, as its client's FrameReceived reports show it: frames on their way (written, not yet
// reported), the time a frame takes to arrive, the link's capacity (the most that frames larger than the quickest
// delivered one read of it, or what frames queued behind one another at it read) and its settled rate (never from the
// sender's own spacing), and from these when
// the next Frame may be written (and when it is expected to be: a video frame is encoded ahead of it) and at what
// bitrate a video stream should run (the link's share, and no more than keeps the client's pace). A client that
// reports keeps at most kFramesInFlight Frames on the link (one more while none queues), so frames never queue in
// the network's buffers: a newer frame waits at the server, where latest-wins replaces it, instead of behind older
// ones on a slow link. No sockets, no clock of its own: every call is given the time (tests drive it with made-up
// times).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <deque>
#include <optional>

namespace voxbrick::server {

class LinkPacer {
 public:
  using Clock = std::chrono::steady_clock;
  /// Frames written and not yet reported that hold back the next one: two keep the link busy across a round trip
  /// while a frame travels, and bound the wait a frame adds to one frame's transfer.
  static constexpr int kFramesInFlight = 2;
  /// One frame more may be on its way while the link shows no queue: each of the last kRecentDeliveries deliveries
  /// took at most kNoQueueMs longer than the quickest. Two frames a round trip held a drag on a far link (80 ms) to
  /// about 22 frames a second though its frames passed in 2 ms; on a slow link, where a frame's own bytes take
  /// longer than that, the third frame would only queue.
  static constexpr double kNoQueueMs = 4;
  /// The frames that may be on their way now (kFramesInFlight, or one more: kNoQueueMs).
  int framesInFlightAllowed() const;
  /// A frame not reported this long after it was written: the client is taken to have stopped reporting, and frames
  /// go out unpaced until its next report.
  static constexpr double kStaleMs = 1000;
  /// Video bitrates: never below this (kbit/s).
  static constexpr double kMinKbps = 150;
  /// The share of the link's measured rate a video stream is given, so that its frames do not fill the link.
  static constexpr double kLinkShare = 0.7;

  /// A Frame of `bytes` (whole message) started to be written at `at`; `video`: one of the video stream (their
  /// deliveries hold its bitrate to the client's pace, videoKbps).
  void sent(uint64_t bytes, Clock::time_point at, bool video = false);
  /// A FrameReceived arriving at `at`: it reports the oldest frame on its way (reports pair with frames in order).
  /// Returns false (and changes nothing) when no written frame was waiting for a report.
  bool received(Clock::time_point at);

  /// Whether the next Frame may be written now: the client does not report, fewer than framesInFlightAllowed are on
  /// their way, or the oldest has gone unreported for kStaleMs.
  bool mayWrite(Clock::time_point now) const;
  /// When a Frame held back now may be written at the latest (the oldest frame on its way going stale).
  Clock::time_point releaseAt() const;
  /// When the link is expected to have room for the next Frame: now if it has, else when the oldest frame on its way
  /// should be reported (its write plus the median of the last kRecentDeliveries deliveries); none before a delivery.
  /// A video frame is encoded ahead of it, so that the encoding is not part of the time between frames.
  std::optional<Clock::time_point> roomExpectedAt(Clock::time_point now) const;
  /// Whether the client has reported a frame and has not gone stale since.
  bool reporting() const { return mReporting; }
  int inFlight() const { return int(mReporting ? mOnTheWay.size() : 0); }
  /// When the client's last report arrived (none before the first).
  Clock::time_point lastReport() const { return mLastReport; }

  /// The shortest time from a frame's write to its report over the session (a round trip plus the smallest frame's
  /// transfer); none before the first report.
  std::optional<double> minDeliveryMs() const;
  /// The last frame's time from write to report.
  std::optional<double> lastDeliveryMs() const;
  /// The link's capacity as a video stream's bitrate follows it (kbit/s), if read within the last two seconds.
  /// Where the link is full (at least three of the last six frames reported queued at it: each reached it before the
  /// one ahead had passed it, written earlier than that one's report less the quickest delivery), the median of what
  /// those read: their bytes over the time between their report and the one ahead (frames under 4 KiB only where five
  /// of the last six queued and the time between their reports followed their sizes: queuedReading). Else the most any
  /// other frame 4 KiB or more larger than the quickest delivered one read since the link was last full: its extra
  /// bytes over its time beyond the quickest delivery (the round trip cancels). Each such reading is at most what the
  /// link carries (a late report or the client's own delays make it lower, never higher), so the most of them; a
  /// smoothed rate of both kinds followed every late report down (a busy Chromium's reports, a few ms late each, read
  /// a 10 Mbit/s link at 1 to 3 Mbit/s while a drag's frames kept up with it, and its video ran at 1 Mbit/s with 4 KB
  /// frames, 36 dB, in place of its 4.7 Mbit/s cap). Frames alike in size that keep up read nothing.
  std::optional<double> capacityKbps(Clock::time_point now) const;
  /// The link's rate as measurements settled it, however long ago (none before): by a frame of kConclusiveBytes or
  /// more on its own (its extra bytes over its extra time, as capacityKbps; a frame 32 KiB or more larger than the
  /// quickest delivered one measures), or by three measurements in a row that agree (their median) from frames of
  /// 4 KiB or more that queued behind the one ahead of it (written before that one was reported, and delivered later
  /// than the quickest delivery: the time between their reports is its transfer; or, larger than the quickest
  /// delivered frame, the extra bytes over the extra time, where that reads more). Frames that only overlap on a far
  /// link, each delivered in the quickest time, measure nothing: the time between their reports is the sender's
  /// spacing. Lossless frames are encoded by it (pngSpeedFor, webpFor): a link that keeps up with a drag's frames
  /// measures nothing new, and the exact frame after the drag should still know the rate the last large frame found;
  /// but a choice that lasts must not follow one client's hiccup (a busy browser's report late by tens of ms reads a 9 KB frame's
  /// loopback as a few Mbit/s, and one late before it as 100 Mbit/s).
  std::optional<double> settledLinkKbps() const;
  /// A frame this large measures the link on its own for settledLinkKbps: a report late by up to 40 ms (the most a
  /// busy headless Chromium on two cores showed) reads it no slower than 13 Mbit/s, above the lossless encodings'
  /// thresholds.
  static constexpr uint64_t kConclusiveBytes = 64 * 1024;

  /// The bitrate a video stream should run at now, at most `capKbps`: kLinkShare of the link's capacity
  /// (capacityKbps), else (no recent reading: the link kept up) the last target raised by half a second, starting
  /// from `startKbps`, or held where the last kRecentDeliveries video frames took more than kRaiseWaitMs past the
  /// quickest delivery (their median).
  /// And at most what the client's pace allows: `paceMs` is the most a video frame may take from write to report
  /// for the stream to keep the client's rate (kFramesInFlight of its intervals between Renders). Where the last
  /// kRecentDeliveries video frames took longer than the quickest delivery by more than kPaceShare of `paceMs` less
  /// that quickest delivery, the bitrate comes down in proportion to what their own bytes took (at the link's capacity
  /// or settled rate) and what the pace leaves them once the rest (the client's own delays) is counted: smaller
  /// frames pass sooner and keep the pace. Nothing changes where the round trip alone, or the client's own delays,
  /// already take (most of) the pace, and nothing is cut where the link's rate is unknown. Frames whose bytes take
  /// well within what the pace leaves them (the whole time past the quickest delivery, where the rate is unknown)
  /// lift that limit again a step at a time. A limit changes once per kRecentDeliveries frames
  /// written after it.
  double videoKbps(double startKbps, double capKbps, Clock::time_point now, std::optional<double> paceMs = {});
  /// Video frames that take longer than this past the quickest delivery (the median of the last kRecentDeliveries)
  /// wait at the link, or behind the client's delays: where nothing reads the link, the bitrate is held, not raised
  /// (ms; a browser's reports come up to 8 ms late without a queue). Raised there, a stream whose frames were too
  /// small and too alike to read a link that slowed to 1 Mbit/s under a 60 ms round trip took all of it, and its
  /// frames' p99 latency rose to 135 ms where 89 held before (bench_link_pacer --drop).
  static constexpr double kRaiseWaitMs = 10;
  /// Deliveries that predict the next (roomExpectedAt) and hold a video stream to its pace (videoKbps).
  static constexpr size_t kRecentDeliveries = 3;
  /// The share of the client's pace a video frame's delivery is held to.
  static constexpr double kPaceShare = 0.9;
  /// The interval between a drag's Renders the pace is held to at most (ms; 30 a second): a client that asks slower
  /// than that because it waits for the server's frames (the viewer keeps three Renders unanswered) would otherwise
  /// let them grow and come slower still (a two-core Chromium over a 10 Mbit/s link asked every 50 to 60 ms once its
  /// stream ran at its 4.7 Mbit/s cap, and showed 17 to 20 frames a second).
  static constexpr double kDragIntervalMs = 1000.0 / 30;
  /// videoKbps' `paceMs` for a client whose Renders come `renderIntervalMs` apart (the median of its recent ones):
  /// kFramesInFlight of them, each at most kDragIntervalMs.
  static double paceMsFor(double renderIntervalMs) {
    return kFramesInFlight * std::min(renderIntervalMs, kDragIntervalMs);
  }

 private:
  struct OnTheWay {
    uint64_t bytes = 0;
    Clock::time_point at;
    bool video = false;
  };
  struct Delivery {
    double ms = 0;
    Clock::time_point sentAt;
    uint64_t bytes = 0;
  };
  /// The median of `deliveries`' times (none if empty).
  static std::optional<double> medianMs(const std::deque<Delivery>& deliveries);
  /// The median of the last kRecentDeliveries video frames' times past the quickest delivery (none before).
  std::optional<double> videoWaitMs() const;
  /// videoKbps' limit from the client's pace, given the target the link allows and the link's rate (its capacity,
  /// read once a frame, else its settled rate; none: unknown).
  void followPace(double paceMs, double targetKbps, std::optional<double> link, Clock::time_point now);
  std::deque<OnTheWay> mOnTheWay;
  bool mReporting = false;
  Clock::time_point mLastReport{};
  std::optional<double> mMinDeliveryMs;
  uint64_t mMinDeliveryBytes = 0;  ///< the bytes of the frame delivered quickest
  struct Sample {
    double kbps = 0;
    uint64_t bytes = 0;  ///< of the frame that measured it
  };
  /// A measurement: it settles the link's rate (settledLinkKbps) if large enough, or if it agrees with the two before.
  void settle(Sample sample);
  std::deque<Sample> mRecent;  ///< the last three measurements
  double mSettledKbps = 0;
  /// What one frame's report read of the link's capacity (capacityKbps): its extra bytes over its extra time, and
  /// where it queued at the link, its bytes over the time since the report ahead.
  struct Reading {
    Clock::time_point at;
    std::optional<double> extraKbps, queuedKbps;
    uint64_t bytes = 0;  ///< the frame's
  };
  std::deque<Reading> mReadings;  ///< of every report of the last two seconds
  Clock::time_point mFullAt{};    ///< the last report that found the link full (queuedReading)
  /// The median of what the frames that queued at the link read, if at least kQueuedReadings of the last twice as
  /// many reported did (the link is full), counting frames of 4 KiB or more; else, frames of any size, if all but one
  /// of the last six did, their sizes differ (the largest at least 1.25 times the smallest) and what they read varies
  /// less than half as much as their bytes (in the logarithm of the ratio): the link passed each in its bytes' time. A
  /// busy page reports each small frame after its own time whatever its size, and frames alike in size cannot tell
  /// the two apart.
  static std::optional<double> queuedReading(const std::deque<Reading>& readings);
  double mTargetKbps = 0;
  Clock::time_point mTargetAt{};
  std::deque<Delivery> mRecentDeliveries, mVideoDeliveries;  ///< the last kRecentDeliveries of each
  double mPaceKbps = 0;  ///< the limit the client's pace set (0: none)
  Clock::time_point mPaceChangedAt{};
};

}  // namespace voxbrick::server
