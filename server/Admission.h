// Which connections the server takes, and which become sessions: the count of sessions (max_sessions), of
// connections still waiting for their Hello (max_pending_connections) and of connections per client address
// (max_connections_per_address). No sockets and no lock: the server calls it under its own mutex.
#pragma once

#include <compare>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace voxbrick::server {

/// One accepted connection, numbered by the server in the order of acceptance.
struct ConnectionId {
  uint64_t value = 0;
  friend auto operator<=>(const ConnectionId&, const ConnectionId&) = default;
};

class Admission {
 public:
  struct Limits {
    size_t maxSessions = 64;   ///< greeted connections
    size_t maxPending = 16;    ///< connections without Hello yet
    size_t maxPerAddress = 0;  ///< connections (pending or greeted) of one address; 0: no limit
  };

  /// What admit() decided.
  struct Verdict {
    enum class Result {
      Pending,             ///< taken: it waits for its Hello
      TooManySessions,     ///< refused: max_sessions greeted connections are open
      TooManyFromAddress,  ///< refused: its address holds max_connections_per_address already
    };
    Result result = Result::Pending;
    /// A pending connection to close to make room for this one (max_pending_connections were waiting).
    std::optional<ConnectionId> evicted;
  };

  explicit Admission(Limits limits) : mLimits(limits) {}

  /// A new connection `id` (larger than every id before) from `address`; `limited` says whether the per-address
  /// limit applies to it (loopback may be exempt). A refused one is not remembered. When the pending connections
  /// are at their limit, the new one is taken and the oldest pending connection of the address with the most of
  /// them is evicted: a client that says Hello at once is never kept out by connections that do not speak, and a
  /// single flooding address evicts its own connections first.
  Verdict admit(ConnectionId id, const std::string& address, bool limited);
  /// Hello of `id` was accepted: returns whether it may become a session (false if max_sessions are open, or it
  /// was evicted or is unknown). Idempotent for a session.
  bool greet(ConnectionId id);
  /// `id` closed (pending, greeted, evicted or unknown).
  void remove(ConnectionId id);

  size_t sessions() const { return mSessions; }
  size_t pending() const { return mPending; }
  /// Connections counted against `address`.
  size_t fromAddress(const std::string& address) const;

 private:
  enum class State { Pending, Session, Evicted };
  struct Entry {
    std::string address;
    State state = State::Pending;
  };
  /// The pending connection to evict: the oldest of the address with the most pending ones.
  std::optional<ConnectionId> evictionCandidate() const;

  Limits mLimits;
  std::map<ConnectionId, Entry> mConnections;  ///< ordered by id: oldest first
  std::map<std::string, size_t> mPerAddress;   ///< connections of each address (evicted ones until they close)
  size_t mSessions = 0, mPending = 0;
};

}  // namespace voxbrick::server
