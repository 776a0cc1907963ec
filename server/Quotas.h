// Per-address and per-token quotas ([quotas] in server.toml): how many sessions one client address or one access
// token may hold, and how many Renders a second they may send. No sockets; thread-safe.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "server/Admission.h"
#include "server/ServerConfig.h"

namespace voxbrick::server {

class Quotas {
 public:
  using Clock = std::chrono::steady_clock;
  explicit Quotas(const QuotaConfig& config) : mConfig(config) {}

  /// Session `id` of `address` (loopback or not) with access token `token` (empty: none) was greeted: none when it
  /// may become a session (it is then counted), else why not ("quota: ..."). Each id once.
  std::optional<std::string> admit(ConnectionId id, const std::string& address, bool loopback,
                                   const std::string& token);
  /// `id` closed (admitted or not).
  void remove(ConnectionId id);

  struct Refusal {
    uint32_t retryAfterMs = 0;
    std::string why;
  };
  /// A Render of session `id` at `now`: none when its address and token have room (one frame is taken from each),
  /// else the time until they do. A session not admitted here is held to nothing.
  std::optional<Refusal> takeFrame(ConnectionId id, Clock::time_point now = Clock::now());

 private:
  /// A frame rate as a token bucket holding a second's frames (at least one).
  struct Bucket {
    double frames = -1;  ///< -1: full
    Clock::time_point updated{};
  };
  struct Holder {
    size_t sessions = 0;
    Bucket bucket;
  };
  struct Entry {
    std::string address, token;
  };
  /// Refills `bucket` at `rate` a second up to max(1, rate); the ms until it holds one frame (0: it does now).
  static double refill(Bucket& bucket, double rate, Clock::time_point now);

  const QuotaConfig mConfig;
  std::mutex mMutex;
  std::map<ConnectionId, Entry> mSessions;  ///< admitted, not exempt
  std::map<std::string, Holder> mAddresses, mTokens;
};

}  // namespace voxbrick::server
