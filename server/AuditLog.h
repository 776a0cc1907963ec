// The audit trail: one line of JSON per session opened, token presented, dataset opened and refusal, with the UTC
// time, the client's address, the transport and the token's id (never its secret), appended to the file of [audit]
// path and rotated by size (path.1 the newest of the old ones, up to path.KEEP). Never frames or pixels. Thread-safe;
// recording never throws (a file that cannot be written is said in the server's log, once).
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <string>

namespace voxbrick::server {

/// One line of the trail.
struct AuditEvent {
  /// "session" (a connection's Hello was accepted), "token" (a session presented a token: Authenticate), "dataset"
  /// (a dataset opened), "uploaded" (an upload became a dataset), "refused" (a connection, Hello, token, upgrade, TLS
  /// handshake, dataset or upload refused).
  std::string event;
  std::string client;     ///< address:port
  std::string transport;  ///< "tcp", "tls", "ws" or "wss"
  std::string token;      ///< the token's id; empty: none
  std::string dataset;    ///< a dataset opened or refused; empty: none
  std::string reason;     ///< why a refusal; empty for the others
};

class AuditLog {
 public:
  using Clock = std::chrono::system_clock;

  /// No trail: record() does nothing.
  AuditLog() = default;
  /// Appends to `path` (created with mode 0600), rotating once it would pass `maxBytes`, keeping `keep` old files.
  /// Throws std::runtime_error naming the file when it cannot be opened for appending.
  AuditLog(std::filesystem::path path, uint64_t maxBytes, int keep);
  ~AuditLog();
  AuditLog(const AuditLog&) = delete;
  AuditLog& operator=(const AuditLog&) = delete;

  bool enabled() const { return !mPath.empty(); }
  /// Appends `event` at `when`.
  void record(const AuditEvent& event, Clock::time_point when = Clock::now());
  /// The line `event` at `when` is: a JSON object, its keys time (UTC, ISO 8601 to the millisecond), event, client,
  /// transport, token (null for none), then dataset and reason where they are set; and a newline.
  static std::string line(const AuditEvent& event, Clock::time_point when);

 private:
  void open();
  /// Renames path.N to path.N+1 down to path -> path.1 (the oldest beyond `keep` is dropped), and opens a new file.
  void rotate();

  std::filesystem::path mPath;
  uint64_t mMaxBytes = 0;
  int mKeep = 0;
  std::mutex mMutex;
  int mFd = -1;
  uint64_t mBytes = 0;  ///< of the file now written
  bool mFailed = false;  ///< a write failed: said once in the log
};

}  // namespace voxbrick::server
