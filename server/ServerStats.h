// The server's statistics: event counters, refusals by reason, frames by class and encoding, frame latencies and
// resident memory; the Stats message's JSON and the Prometheus text of /metrics.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/EnumNames.h"
#include "proto/Messages.h"
#include "render/core/Dataset.h"
#include "server/FrameClass.h"
#include "server/LatencyWindow.h"
#include "server/Metrics.h"
#include "server/VideoScaledFor.h"

namespace voxbrick::server {

/// What the server counts.
enum class ServerEvent {
  SessionAccepted,  ///< connections whose Hello made them a session
  SessionRefused,   ///< connections refused: too many sessions or of one address, stopping, a forbidden upgrade
  PendingEvicted,   ///< connections without Hello closed to make room for a newer one
  Message,          ///< message bodies read, decodable or not
  ProtocolError,    ///< headers and bodies that did not decode
  RenderRequest,
  Frame,
  RenderError,  ///< renders answered with an Error instead of a Frame
  Superseded,
  Refined,            ///< exact frames sent after a provisional one (progressive scenes)
  Timeout,            ///< sessions closed idle or mid-message
  SlowClientDropped,  ///< sessions closed because they did not read their replies
  ReadingPaused,      ///< times a session was not read because its replies waited unread
  OutputRefused,      ///< frames answered LimitExceeded (or dropped) because of the server's output budget
  Uploaded,           ///< uploads prepped into datasets
  UploadRefused,      ///< uploads refused, abandoned for a bad chunk, or whose prep failed
};

/// Why the server turned a connection or a request away (Prometheus' voxbrick_refusals_total{reason}).
enum class Refusal : uint8_t {
  Sessions,        ///< a connection or Hello beyond max_sessions
  Address,         ///< a connection beyond max_connections_per_address
  PendingEvicted,  ///< a connection without Hello closed to make room for a newer one
  Output,          ///< a frame beyond the server's output budget (max_total_output_bytes)
  Busy,            ///< a Render refused because the render queue is full (the scheduler's admission)
  Quota,           ///< a Render refused because its session or address used up its share
  Stopping,        ///< a connection while the server stops
  Forbidden,       ///< a WebSocket upgrade refused for its Origin or access token, or a wrong token (Authenticate)
  Tls,             ///< a TLS handshake that failed (an old protocol version, no shared cipher, an untrusted client)
};
inline constexpr size_t kRefusals = size_t(Refusal::Tls) + 1;
inline constexpr common::EnumName<Refusal> kRefusalNames[] = {
    {Refusal::Sessions, "sessions"}, {Refusal::Address, "address"},     {Refusal::PendingEvicted, "pending_evicted"},
    {Refusal::Output, "output"},     {Refusal::Busy, "busy"},           {Refusal::Quota, "quota"},
    {Refusal::Stopping, "stopping"}, {Refusal::Forbidden, "forbidden"}, {Refusal::Tls, "tls"}};
constexpr std::span<const common::EnumName<Refusal>> enumNames(Refusal) { return kRefusalNames; }

/// The frame encodings counted apart, in proto::Encoding's value order.
inline constexpr size_t kFrameEncodings = size_t(proto::Encoding::Webp) + 1;

/// Counters are atomics: every I/O and render thread updates them without a lock.
class ServerStats {
 public:
  /// What the server knows at the moment statistics are asked for (the counters are kept here).
  struct Gauges {
    size_t activeSessions = 0;                                     ///< connections past Hello
    size_t queuedSessions = 0;                                     ///< sessions with a render waiting for a thread
    std::vector<std::shared_ptr<const render::Dataset>> datasets;  ///< the opened ones
    int renderThreads = 0;
    /// The render threads' atlases (RenderScheduler::gpu(): this header does not include the scheduler's, so that
    /// the scheduler may include this one).
    struct Gpu {
      size_t bytes = 0, peakBytes = 0;  ///< peakBytes: the sum of each thread's peak
      uint64_t renderersReleased = 0;
    } gpu;
    size_t gpuBudgetBytes = 0;
    size_t pendingConnections = 0;                                              ///< accepted, no Hello yet
    uint64_t outputQueuedBytes = 0, outputPeakBytes = 0, outputLimitBytes = 0;  ///< replies not yet written
    nlohmann::json limits = nlohmann::json::object();   ///< the configuration's limits, for clients and load tests
    uint64_t rendersCancelled = 0;                      ///< frames given up part way (RenderScheduler::cancelled)
    size_t tcpSessions = 0, webSocketSessions = 0;      ///< activeSessions by transport
    std::array<size_t, kFrameClasses> queuedByClass{};  ///< jobs waiting (RenderScheduler::queuedByClass)
    std::array<size_t, kFrameClasses> encodesByClass{};  ///< encodings waiting (EncoderQueue::queued)
    std::vector<double> deviceBusyMs{};  ///< each render thread's time drawing (RenderScheduler::deviceBusyMs)
    std::vector<double> deviceWaitMs{};  ///< each render thread's time asking for a job (RenderScheduler::deviceWaitMs)
    size_t draggingSessions = 0;     ///< sessions that sent an interactive Render within the last second
    size_t interactiveCapacity = 0;  ///< RenderScheduler::interactiveCapacity: 0 while not measured (no limit)
    size_t waitingToDrag = 0;        ///< RenderScheduler::waitingToDrag: sessions in line to drag
    uint64_t dragTurnsEnded = 0;     ///< RenderScheduler::turnsEnded
    /// The sessions' video encoders (VideoMemory): how many, the bytes counted for them (now, and the most since
    /// the server started) and the budget, encoders freed for another stream's, and moving frames sent as JPEG for
    /// want of room.
    struct Video {
      size_t encoders = 0;
      uint64_t bytes = 0, peakBytes = 0, limitBytes = 0, freed = 0, jpegFrames = 0;
    } video{};
  };

  /// The upper bounds of the frame latency histogram, in seconds.
  static constexpr std::array<double, 12> kLatencyBoundsS = {0.005, 0.01, 0.025, 0.05, 0.075, 0.1,
                                                             0.25,  0.5,  1,     2.5,  5,     10};

  /// Counts one `event`. SessionRefused, PendingEvicted and OutputRefused count as refusals too (as sessions,
  /// pending_evicted and output): refused() says more.
  void add(ServerEvent event);
  /// How many `event`s were counted since the server started.
  uint64_t total(ServerEvent event) const { return mCounts[size_t(event)].load(); }
  /// Counts a connection, request or frame turned away for `reason`, and its ServerEvent where it has one
  /// (SessionRefused for sessions, address, stopping and forbidden). Thread-safe, as every method here.
  void refused(Refusal reason);
  /// How many were turned away for `reason`.
  uint64_t refusals(Refusal reason) const { return mRefusals[size_t(reason)].load(); }
  /// Counts a Render accepted for rendering (handed to the scheduler), of class `frameClass`.
  void renderAccepted(FrameClass frameClass);
  /// Counts a Frame answering a Render of class `frameClass`, in `encoding`, of `bytes` (the encoded message),
  /// delivered `latencyMs` after its request arrived.
  void frameDelivered(FrameClass frameClass, proto::Encoding encoding, uint64_t bytes, double latencyMs);
  /// Counts one render delivered to a further session that asked for the same frame.
  void frameShared() { mFramesShared++; }
  /// Counts a video frame encoded in `codec` (vp8 or vp9) in `encodeMs`; a key frame names its reason
  /// (kVideoKeyReasons; an inter frame: empty), a frame sent smaller than its scene why.
  void videoEncoded(proto::Encoding codec, double encodeMs, std::string_view keyReason,
                    VideoScaledFor scaledFor = VideoScaledFor::None);
  /// Why a video stream's key frames were sent (PROTOCOL.md, Session 11), as /metrics labels them.
  /// "encoder" stays last: a reason not listed is counted as the encoder's.
  static constexpr std::array<std::string_view, 8> kVideoKeyReasons = {
      "start", "codec", "size", "dataset", "asked", "recovery", "memory", "encoder"};
  /// The upper bounds of the video encode time histogram, in seconds.
  static constexpr std::array<double, 9> kEncodeBoundsS = {0.001, 0.0025, 0.005, 0.01, 0.02, 0.035, 0.05, 0.1, 0.25};

  /// Counts `bytes` of protocol messages written to a client, whatever the transport.
  void bytesWritten(uint64_t bytes) { mBytesOut += bytes; }

  /// The Stats message's JSON: uptime, sessions, messages, renders, latency_ms, datasets (with their cache
  /// counters), memory, output, gpu, limits and render_threads.
  nlohmann::json toJson(const Gauges& gauges) const;
  /// The Prometheus text of /metrics (docs/server.md lists every family).
  std::string metricsText(const Gauges& gauges) const;

 private:
  /// The Stats JSON's `video`: frames encoded and their mean encode ms by codec, key frames by reason, the encoders'
  /// memory.
  nlohmann::json videoJson(const Gauges::Video& memory) const;

  static constexpr size_t kEvents = size_t(ServerEvent::UploadRefused) + 1;
  using Counter = std::atomic<uint64_t>;
  std::array<Counter, kEvents> mCounts{};
  std::array<Counter, kRefusals> mRefusals{};
  std::array<Counter, kFrameClasses> mAccepted{};
  std::array<std::array<Counter, kFrameEncodings>, kFrameClasses> mFrames{}, mFrameBytes{};
  static_assert(kFrameClasses == 3, "one latency histogram per class below");
  std::array<Histogram, kFrameClasses> mLatencyByClass = {Histogram(kLatencyBoundsS), Histogram(kLatencyBoundsS),
                                                          Histogram(kLatencyBoundsS)};
  Counter mFramesShared{0}, mBytesOut{0};
  std::array<Counter, kVideoKeyReasons.size()> mVideoKeyFrames{};
  std::array<Counter, kVideoScaledForCount> mVideoScaled{};  ///< by VideoScaledFor (None's unused)
  std::array<Histogram, 2> mVideoEncode = {Histogram(kEncodeBoundsS), Histogram(kEncodeBoundsS)};  ///< vp8, vp9
  LatencyWindow mLatency;
  std::chrono::steady_clock::time_point mStarted = std::chrono::steady_clock::now();
};

}  // namespace voxbrick::server
