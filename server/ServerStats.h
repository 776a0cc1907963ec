// The server's statistics: event counters, frame latencies and resident memory, and the Stats message's JSON.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/core/Dataset.h"
#include "server/LatencyWindow.h"
#include "server/RenderScheduler.h"

namespace voxbrick::server {

/// What the server counts.
enum class ServerEvent {
  SessionAccepted,  ///< connections whose Hello made them a session
  SessionRefused,   ///< too many sessions or connections of one address, or stopping
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
};

/// Counters are atomics: every I/O and render thread updates them without a lock.
class ServerStats {
 public:
  /// What the server knows at the moment statistics are asked for (the counters are kept here).
  struct Gauges {
    size_t activeSessions = 0;                                     ///< connections past Hello
    size_t queuedSessions = 0;                                     ///< sessions with a render waiting for a thread
    std::vector<std::shared_ptr<const render::Dataset>> datasets;  ///< the opened ones
    int renderThreads = 0;
    RenderScheduler::GpuGauges gpu;  ///< the render threads' atlases
    size_t gpuBudgetBytes = 0;
    size_t pendingConnections = 0;                                              ///< accepted, no Hello yet
    uint64_t outputQueuedBytes = 0, outputPeakBytes = 0, outputLimitBytes = 0;  ///< replies not yet written
    nlohmann::json limits = nlohmann::json::object();  ///< the configuration's limits, for clients and load tests
    uint64_t rendersCancelled = 0;                     ///< frames given up part way (RenderScheduler::cancelled)
  };

  /// Counts one `event`.
  void add(ServerEvent event) { mCounts[size_t(event)]++; }
  /// How many `event`s were counted since the server started.
  uint64_t total(ServerEvent event) const { return mCounts[size_t(event)].load(); }
  /// Counts a Frame delivered `latencyMs` after its request arrived.
  void frameDelivered(double latencyMs);

  /// The Stats message's JSON: uptime, sessions, messages, renders, latency_ms, datasets (with their cache
  /// counters), memory, output, gpu, limits and render_threads.
  nlohmann::json toJson(const Gauges& gauges) const;

 private:
  static constexpr size_t kEvents = size_t(ServerEvent::OutputRefused) + 1;
  std::array<std::atomic<uint64_t>, kEvents> mCounts{};
  LatencyWindow mLatency;
  std::chrono::steady_clock::time_point mStarted = std::chrono::steady_clock::now();
};

}  // namespace voxbrick::server
