// The render service: a Boost.Asio server speaking proto/PROTOCOL.md over TCP and, on an HTTP port of its own, over
// WebSocket. It accepts connections, wires the parts (sessions, MessageHandler, RenderScheduler, ServerStats)
// together, and runs the lifecycle: signals, shutdown, waiting for sessions to flush. It holds each connection as a
// Session, whatever its transport (TcpSession, WebSocketSession).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "render/engine/FrameSource.h"
#include "server/ServerConfig.h"

namespace voxbrick::server {

/// One local engine per render thread (config.renderThreads), each with an equal share of the GPU budget, made on
/// the calling thread and released there, so that a machine without GL fails at startup with an error, not with
/// threads left running.
std::vector<std::unique_ptr<render::FrameSource>> makeLocalSources(const ServerConfig& config);

class Server {
 public:
  /// Reads the transfer-function presets, makes the render threads' engines (GL contexts; makeLocalSources) and
  /// binds the listening socket, all before any thread starts; throws std::runtime_error naming the problem (no GL,
  /// address in use, unreadable datasets directory).
  explicit Server(const ServerConfig& config);
  /// The same with the given frame sources, one per render thread (config.renderThreads is not used): the
  /// distributed mode's, or the null source of tests without GL. Each is released from the calling thread.
  Server(const ServerConfig& config, std::vector<std::unique_ptr<render::FrameSource>> sources);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// The port actually bound (the configured one, or the one the system picked for port 0).
  int port() const;
  /// The HTTP port actually bound (config.http), or 0 when the server does not listen for HTTP.
  int httpPort() const;
  /// Serves until stop() or SIGINT/SIGTERM; then closes every session (ShuttingDown), lets running renders finish
  /// and returns.
  void run();
  /// Asks run() to return; safe from any thread, also before run() is called.
  void stop();
  /// Server statistics as JSON (what a Stats message carries).
  std::string statsJson() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> mImpl;
};

}  // namespace voxbrick::server
