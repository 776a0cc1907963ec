// The render service: a Boost.Asio TCP server speaking proto/PROTOCOL.md. I/O runs on a pool of Asio threads;
// frames are rendered by dedicated render threads, each with its own GL context and renderers; a render queue
// serves sessions in turn and keeps only the newest request of each (latest wins).
#pragma once

#include <memory>
#include <string>

#include "server/ServerConfig.h"

namespace voxbrick::server {

struct Session;

class Server {
 public:
  /// Creates the render threads' GL contexts and binds the listening socket; throws std::runtime_error naming the
  /// problem (no GL, address in use, unreadable datasets directory).
  explicit Server(const ServerConfig& config);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// The port actually bound (the configured one, or the one the system picked for port 0).
  int port() const;
  /// Serves until stop() or SIGINT/SIGTERM; then closes every session (ShuttingDown), lets running renders finish
  /// and returns.
  void run();
  /// Asks run() to return; safe from any thread.
  void stop();
  /// Server statistics as JSON (what a Stats message carries).
  std::string statsJson() const;

 private:
  friend struct Session;
  struct Impl;
  std::unique_ptr<Impl> mImpl;
};

}  // namespace voxbrick::server
