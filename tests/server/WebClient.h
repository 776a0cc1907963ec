// Test clients of the browser transport: one HTTP request at a time, and the protocol over a WebSocket (Boost.Beast,
// synchronous) as the viewer's page speaks it; both in the clear or over TLS (https://, wss://).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "proto/Messages.h"

namespace voxbrick::test {

/// An HTTP reply: status, headers (names in lower case), body.
struct HttpReply {
  int status = 0;
  std::map<std::string, std::string> headers;
  std::string body;
  std::string header(const std::string& lowerName) const {
    const auto it = headers.find(lowerName);
    return it == headers.end() ? std::string() : it->second;
  }
};

/// Sends one request (HTTP/1.1, Host 127.0.0.1:`port`, `target` sent as given, not normalised) and reads its reply.
HttpReply httpRequest(int port, const std::string& method, const std::string& target,
                      const std::vector<std::pair<std::string, std::string>>& headers = {});
/// The same over TLS, the server's certificate verified against the CAs of `caFile` (and made out to 127.0.0.1).
HttpReply httpsRequest(int port, const std::string& caFile, const std::string& method, const std::string& target);

/// The server declined the WebSocket upgrade with this HTTP reply.
class UpgradeRefused : public std::runtime_error {
 public:
  UpgradeRefused(int httpStatus, std::string text)
      : std::runtime_error("upgrade refused: HTTP " + std::to_string(httpStatus) + ": " + text),
        status(httpStatus),
        body(std::move(text)) {}
  int status;
  std::string body;
};

/// One session over ws://127.0.0.1:port/ws (or wss://). Replies are read with a timeout (a ConnectionError past it);
/// an Error answering a request made through the helpers is thrown as client::ServerError.
class WebSocketClient {
 public:
  /// Opens `target` (e.g. "/ws?token=x") with an Origin header when `origin` is not empty; throws UpgradeRefused.
  /// With `caFile`, over TLS (wss://), the server's certificate verified against its CAs.
  explicit WebSocketClient(int port, const std::string& target = "/ws", const std::string& origin = "",
                           std::chrono::milliseconds timeout = std::chrono::seconds(60),
                           const std::string& caFile = "");
  ~WebSocketClient();
  WebSocketClient(const WebSocketClient&) = delete;
  WebSocketClient& operator=(const WebSocketClient&) = delete;

  proto::Capabilities hello(const std::string& clientName = "ws-test");
  std::vector<std::string> listDatasets();
  proto::DatasetInfo openDataset(const std::string& name);
  proto::Frame render(const std::string& sceneJson, proto::Encoding encoding = proto::Encoding::Png);
  std::string stats();

  /// Sends `message` in one binary WebSocket message; returns its request id.
  uint32_t send(const proto::Message& message);
  /// Sends `bytes` as one WebSocket message, binary or text.
  void sendRaw(std::span<const uint8_t> bytes, bool binary = true);
  /// The next message and its request id; throws client::ConnectionError when the server closed or time ran out.
  std::pair<uint32_t, proto::Message> receive();
  /// Reads until the server closes; returns the codes of the Errors read on the way.
  std::vector<proto::ErrorCode> errorsUntilClosed();

 private:
  proto::Message call(const proto::Message& message);

  struct Impl;
  std::unique_ptr<Impl> mImpl;
  uint32_t mNextId = 1;
};

}  // namespace voxbrick::test
