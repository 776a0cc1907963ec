// Per-address and per-token quotas ([quotas] in server.toml, and a token's own in [[tokens]]): how many sessions one
// client address or one access token may hold, and how many Renders a second they may send. Tokens are counted by
// their id, never their secret. No sockets; thread-safe.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "server/AccessTokens.h"
#include "server/Admission.h"
#include "server/ServerConfig.h"

namespace voxbrick::server {

class Quotas {
 public:
  using Clock = std::chrono::steady_clock;
  explicit Quotas(const QuotaConfig& config) : mConfig(config) {}

  /// Session `id` of `address` (loopback or not) with access token `token` (null or anonymous: none) was greeted:
  /// none when it may become a session (it is then counted), else why not ("quota: ..."). Each id once. A token's
  /// own quotas (TokenGrant::sessions, framesPerSecond) replace [quotas]' per-token ones.
  std::optional<std::string> admit(ConnectionId id, const std::string& address, bool loopback,
                                   const TokenGrant* token = nullptr);
  /// Session `id`, admitted without a token, presented `token` (Authenticate): none when the token has room (the
  /// session is then counted against it), else why not.
  std::optional<std::string> attachToken(ConnectionId id, const TokenGrant& token);
  /// `id` closed (admitted or not).
  void remove(ConnectionId id);

  struct Refusal {
    uint32_t retryAfterMs = 0;
    std::string why;
  };
  /// A Render of session `id` at `now`: none when its address and token have room (one frame is taken from each),
  /// else the time until they do. A session not admitted here is held to nothing.
  std::optional<Refusal> takeFrame(ConnectionId id, Clock::time_point now = Clock::now());
  /// Gives back the frame takeFrame took for a Render of session `id` that was refused after all (Busy).
  void returnFrame(ConnectionId id);

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
    std::string address, token;  ///< the token's id; empty: none
    int tokenSessions = 0;       ///< the token's sessions quota (0: none)
    double tokenFrames = 0;      ///< its Renders a second (0: none)
  };
  /// Counts `entry`'s session against its token, or says why it may not be.
  std::optional<std::string> countToken(Entry& entry, const TokenGrant& token);
  /// Refills `bucket` at `rate` a second up to max(1, rate); the ms until it holds one frame (0: it does now).
  static double refill(Bucket& bucket, double rate, Clock::time_point now);

  const QuotaConfig mConfig;
  std::mutex mMutex;
  std::map<ConnectionId, Entry> mSessions;  ///< admitted, not exempt
  std::map<std::string, Holder> mAddresses, mTokens;
};

}  // namespace voxbrick::server
