// A TCP connection to the server for clients that misbehave below the message level: never speaking, trickling
// bytes, never reading. It speaks either transport: bare protocol messages on the TCP port, or (Framing WebSocket) the
// same messages each in one WebSocket binary message on the HTTP port's /ws, framed by hand so that a test controls
// every byte; either in the clear or inside TLS (OpenSSL, the handshake done when it connects, the server's
// certificate not checked: a hostile client has no reason to), where what a test sends is the TLS records' content.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "proto/Messages.h"

struct ssl_st;

namespace voxbrick::test {

/// How protocol messages travel.
enum class Framing {
  Tcp,        ///< protocol messages on the TCP port
  WebSocket,  ///< each in one WebSocket binary message on the HTTP port's /ws
  None,       ///< bytes only, nothing parsed (an HTTP client by hand)
};

/// "Tcp" or "WebSocket", to name parameterised tests (the parameter info's `param`).
template <typename ParamInfo>
std::string framingName(const ParamInfo& p) {
  return p.param == Framing::Tcp ? "Tcp" : "WebSocket";
}

class RawSocket {
 public:
  /// Connects to 127.0.0.1:`port`; throws std::runtime_error if it cannot. With Framing::WebSocket, `port` is the
  /// HTTP port: the upgrade of `target` is sent and its reply read (up to 10 s); a refusal (any status but 101)
  /// leaves the socket closed() with refusedStatus() and refusedBody() set. With `tls`, the TLS handshake comes first
  /// (up to 10 s); a server that closes the connection instead (one refused before its handshake) leaves it closed().
  explicit RawSocket(int port, Framing framing = Framing::Tcp, const std::string& target = "/ws", bool tls = false);
  ~RawSocket();
  RawSocket(const RawSocket&) = delete;
  RawSocket& operator=(const RawSocket&) = delete;

  /// The bytes that carry the protocol message `message` (as proto::encode makes it) on this socket's transport.
  std::vector<uint8_t> frame(const std::vector<uint8_t>& message) const;
  /// The bytes that start a message whose first bytes are `first`, the rest to follow (over WebSocket, a first
  /// fragment that is not final).
  std::vector<uint8_t> frameStart(const std::vector<uint8_t>& first) const;
  /// Sends frame(message), blocking; false if the connection failed.
  bool sendMessage(const std::vector<uint8_t>& message) { return sendAll(frame(message)); }
  /// Sends all of `bytes` as they are, blocking; false if the connection failed (the server closed it).
  bool sendAll(const std::vector<uint8_t>& bytes);
  /// Sends what the socket takes now of `bytes` without blocking; returns the count sent (0 when the buffers are
  /// full), or -1 once the connection failed.
  long sendSome(std::span<const uint8_t> bytes);
  /// The next whole message within `timeout`; nullopt if none came in time or the connection closed (closed()).
  std::optional<proto::Message> receive(std::chrono::milliseconds timeout);
  /// receive(), with the message's request id.
  std::optional<std::pair<uint32_t, proto::Message>> receiveWithId(std::chrono::milliseconds timeout);
  /// Reads until the server closes the connection or `timeout` passes; returns whether it closed. The codes of the
  /// Errors read on the way are appended to `codes`.
  bool waitClosed(std::chrono::milliseconds timeout, std::vector<proto::ErrorCode>* codes = nullptr);
  /// Whether the server closed the connection (seen by a read; over WebSocket, a close frame counts).
  bool closed() const { return mClosed; }
  /// The header of the last message receive() returned (its version, its request id).
  const proto::Header& lastHeader() const { return mLastHeader; }
  /// The WebSocket close code the server sent (0: none seen).
  int closeCode() const { return mCloseCode; }
  /// The HTTP status that refused the upgrade (0: not refused, or closed without a reply).
  int refusedStatus() const { return mRefusedStatus; }
  const std::string& refusedBody() const { return mRefusedBody; }

  /// One WebSocket frame from the client: masked, `opcode` (1 text, 2 binary, 0 continuation), final or not.
  static std::vector<uint8_t> webSocketFrame(std::span<const uint8_t> payload, int opcode, bool final);

 private:
  /// Reads what arrives within `timeout` into mInput; false once the connection closed or failed.
  bool fill(std::chrono::milliseconds timeout);
  /// The first whole message of mInput, removed from it.
  std::optional<std::pair<uint32_t, proto::Message>> take();
  /// The payload of the first whole WebSocket message of mInput, removed from it (control frames are consumed).
  std::optional<std::vector<uint8_t>> takeWebSocketMessage();
  void upgrade(int port, const std::string& target);
  /// The TLS handshake on mFd, blocking up to 10 s; the socket is then non-blocking. False if it failed.
  bool handshake();
  /// Writes what TLS takes now of `bytes`: the count (0 when it would block), or -1 once the connection failed.
  long tlsWrite(std::span<const uint8_t> bytes);

  int mFd = -1;
  ssl_st* mSsl = nullptr;  ///< the TLS connection over mFd (null: in the clear)
  Framing mFraming;
  bool mClosed = false;
  int mCloseCode = 0, mRefusedStatus = 0;
  std::string mRefusedBody;
  std::vector<uint8_t> mInput;
  proto::Header mLastHeader;
  std::vector<uint8_t> mFragments;  ///< payload of a WebSocket message whose last frame has not arrived
};

}  // namespace voxbrick::test
