// The latencies of a server's recent frames, for percentiles and frames per second in its statistics.
#pragma once

#include <chrono>
#include <deque>
#include <mutex>

#include <nlohmann/json.hpp>

namespace voxbrick::server {

/// The last few thousand frame latencies with their completion times; thread-safe.
class LatencyWindow {
 public:
  /// Records a frame delivered now that took `ms` from request to reply.
  void record(double ms);
  /// samples, p50, p95, p99, max (milliseconds) and frames_per_s_last_10s.
  nlohmann::json toJson() const;

 private:
  using Clock = std::chrono::steady_clock;
  struct Sample {
    Clock::time_point at;
    double ms;
  };
  static constexpr size_t kKeep = 8192;
  mutable std::mutex mMutex;
  std::deque<Sample> mSamples;
};

}  // namespace voxbrick::server
