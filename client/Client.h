// A small blocking client of the render service (proto/PROTOCOL.md), for programs that want frames: connect,
// hello, open a dataset, render. Link voxbrick_client.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "proto/Messages.h"

namespace voxbrick::client {

/// The server answered with an Error message.
class ServerError : public std::runtime_error {
 public:
  ServerError(proto::ErrorCode code, const std::string& message)
      : std::runtime_error(std::string(proto::errorCodeName(code)) + ": " + message), mCode(code) {}
  proto::ErrorCode code() const { return mCode; }

 private:
  proto::ErrorCode mCode;
};

/// The connection failed, timed out or the server sent bytes that do not decode.
class ConnectionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// How a client reaches the server: in the clear, or over TLS with the server's certificate verified.
struct TlsOptions {
  bool enabled = false;  ///< speak TLS (a server with --tls-cert speaks nothing else)
  std::string caFile;    ///< PEM certificates of the CAs to trust; empty: the system's store
  /// Accept any certificate, unverified (a self-signed one in local use): the link is encrypted, but anyone on the
  /// path could pose as the server.
  bool insecure = false;
  std::string certFile, keyFile;  ///< PEM: a certificate of the client's own, for a server that asks one (tls.ca)
};

/// One session. Not thread-safe: use one Client per thread.
class Client {
 public:
  /// Connects to host:port; `timeout` bounds the connect, the TLS handshake and every later read or write (one that
  /// does not complete in time closes the connection and throws ConnectionError saying so). With `tls.enabled`, the
  /// server's certificate must be signed by a trusted CA (tls.caFile, else the system's) and name `host` (a DNS name
  /// or an IP address), unless tls.insecure. Throws ConnectionError naming the problem (an untrusted certificate, a
  /// name it does not carry, a server that speaks no TLS).
  Client(const std::string& host, int port, std::chrono::milliseconds timeout = std::chrono::seconds(60),
         const TlsOptions& tls = {});
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  /// Hello -> Capabilities: offers protocol versions kMinVersion..`maxVersion` and speaks the one the server picks
  /// from then on (version()).
  proto::Capabilities hello(const std::string& clientName = "voxbrick-client 0.1",
                            uint16_t maxVersion = proto::kMaxVersion);
  /// Whether the session travels over TLS; and if so its version and cipher ("TLSv1.3 TLS_AES_128_GCM_SHA256").
  bool tls() const;
  std::string tlsDescription() const;
  /// The session's protocol version: what Capabilities said, kVersion before Hello.
  uint16_t version() const { return mVersion; }
  /// Version 5 on: presents the access token `token` (Authenticate), which decides the datasets the session may list
  /// and open; returns the token's id. Call it after hello() and before openDataset(). Throws ServerError Forbidden
  /// for a wrong token (the server then closes), std::invalid_argument when the session's version is older.
  std::string authenticate(const std::string& token);
  std::vector<std::string> listDatasets();
  proto::DatasetInfo openDataset(const std::string& name);
  /// One frame of the open dataset: the exact one. For a progressive scene the server may send a provisional Frame
  /// first (isProvisional); it is handed to `onProvisional` if given, and the call waits for the exact Frame. Throws
  /// ServerError (InvalidScene, LimitExceeded, Superseded, ...), std::invalid_argument for an encoding the session's
  /// version lacks (jpeg with a version-1 server).
  proto::Frame render(const std::string& sceneJson, proto::Encoding encoding = proto::Encoding::Png,
                      const std::function<void(const proto::Frame&)>& onProvisional = {});
  /// Version 4 on: tells the server that `frame`, a reply to request `requestId`, arrived (FrameReceived), so that it
  /// keeps this session's frames from queueing on a slow link and sets its video bitrate by what arrives. Call it for
  /// every Frame, in the order they arrive, or never; nothing is sent in an older session.
  void frameReceived(uint32_t requestId, const proto::Frame& frame);
  /// Server statistics (JSON text).
  std::string stats();
  /// Sends Goodbye and closes.
  void goodbye();

  /// Low level: sends a message with a fresh request id and returns the id.
  uint32_t send(const proto::Message& message);
  /// Low level: sends raw bytes as they are (for tests of malformed input).
  void sendBytes(const std::vector<uint8_t>& bytes);
  /// Low level: up to `max` raw bytes as they arrive (for tests of clients that read slowly); empty once closed.
  std::vector<uint8_t> receiveBytes(size_t max);
  /// Low level: the next message from the server, with the request id it answers.
  std::pair<uint32_t, proto::Message> receive();
  /// Low level: waits up to `wait` for bytes from the server (or its closing the connection) without reading any;
  /// whether they came. With it one thread can both send on a schedule and read replies as they come (this class is
  /// not thread-safe: a second thread's receive() would run this thread's send()s).
  bool waitReadable(std::chrono::milliseconds wait);
  /// Closes the socket without a Goodbye.
  void close();

 private:
  /// Sends `message` and returns the reply to it; an Error reply throws ServerError.
  proto::Message call(const proto::Message& message);
  /// The next reply to request `id`, skipping replies to other requests; an Error reply throws ServerError.
  proto::Message awaitReply(uint32_t id);

  struct Impl;
  std::unique_ptr<Impl> mImpl;
  uint32_t mNextId = 1;
  uint16_t mVersion = proto::kVersion;
};

/// The encoding a command-line name gives ("raw", "png", "zstd", "jpeg", "vp8", "vp9", "webp"); throws
/// std::invalid_argument otherwise.
proto::Encoding encodingNamed(const std::string& name);

/// The bytes of the Frame message that carried `frame`, header included (FrameReceived's frame_bytes).
uint32_t frameMessageBytes(const proto::Frame& frame);

/// Whether `frame` is provisional: drawn with stand-ins for bricks not yet resident, the exact Frame of the same
/// request to follow (its statistics' "provisional" key, PROTOCOL.md "Progressive frames").
bool isProvisional(const proto::Frame& frame);

/// How long an Error reply `code` with `message` asks the client to wait before sending the same request again: a
/// Busy reply's retry hint ("; retry after N ms"), kBusyWithoutHint when it names none, or the hint of a LimitExceeded
/// that names one (what a session of protocol version 1 or 2 gets in place of Busy); none for any other error, which
/// asking again would not mend.
inline constexpr std::chrono::milliseconds kBusyWithoutHint{100};
std::optional<std::chrono::milliseconds> retryAfter(proto::ErrorCode code, std::string_view message);

/// "host:port" -> (host, port); throws std::invalid_argument naming the text.
std::pair<std::string, int> parseAddress(const std::string& text);

}  // namespace voxbrick::client
