// The browser's transport of one client connection, on the HTTP port: first HTTP (the embedded viewer's files, and
// the upgrade of /ws, checked by a WebGate), then a WebSocket whose every binary message carries exactly one
// protocol message (header and body, as on TCP), over a plain TCP stream or, for https:// and wss://, a TLS stream
// (its handshake first). Like TcpSession it adds only its stream to AsioSession: the rules (deadlines, admission, the
// reply queue, back-pressure, the output budget) are its Connection's. Until it upgrades it counts as a pending
// connection (one that has not said Hello), and its TLS handshake and each HTTP request must arrive and be answered
// within hello_timeout_s, so a client that trickles a handshake or a request (slowloris) holds nothing for long.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http/message.hpp>
#include <boost/beast/http/parser.hpp>
#include <boost/beast/http/string_body.hpp>
#include <boost/beast/http/vector_body.hpp>
#include <boost/beast/ssl/ssl_stream.hpp>
#include <boost/beast/websocket/stream.hpp>

#include "server/AsioSession.h"
#include "server/WebGate.h"

namespace voxbrick::server {

/// `Stream` is the stream HTTP and the WebSocket travel on: boost::beast::tcp_stream (PlainWebSocketSession) or
/// boost::beast::ssl_stream of it (TlsWebSocketSession).
template <class Stream>
class WebSocketSession final : public AsioSession {
 public:
  static constexpr bool kTls = !std::is_same_v<Stream, boost::beast::tcp_stream>;

  /// `socket` must be connected and bound to a strand executor; `gate` is the server's and outlives the session.
  WebSocketSession(boost::asio::ip::tcp::socket socket, const SessionServices& services, const WebGate& gate,
                   ConnectionId id) requires(!kTls);
  /// The same over TLS with context `tls` (which it keeps): the handshake first.
  WebSocketSession(boost::asio::ip::tcp::socket socket, std::shared_ptr<boost::asio::ssl::context> tls,
                   const SessionServices& services, const WebGate& gate, ConnectionId id) requires(kTls);

  /// Starts serving HTTP (over TLS: the handshake first); the Connection starts (its Hello deadline, reading
  /// messages) once /ws is upgraded.
  void start() override;
  /// After the upgrade as for TCP (the Error, then close); before it HTTP 503 saying why, or over TLS before the
  /// handshake is done, closed at once.
  void end(proto::Error error) override;

  void readMessage() override;
  void write(std::span<const uint8_t> message) override;
  void close() override;
  /// The grant of the token /ws was opened with, once the gate accepted it (null when the server sets none).
  std::shared_ptr<const TokenGrant> accessGrant() const override { return mGrant; }

 private:
  using Request = boost::beast::http::request<boost::beast::http::string_body>;
  using Response = boost::beast::http::response<boost::beast::http::vector_body<uint8_t>>;

  /// Over TLS: the first bytes (a handshake, or a request in the clear, answered in the clear), then the handshake.
  void detectTls();
  void onDetected(boost::system::error_code ec, bool tls);
  void onHandshake(boost::system::error_code ec);
  void readRequest();
  void onRequest(boost::system::error_code ec);
  /// Answers a request that failed to parse (too large a header, a body, garbage) and closes.
  void refuseRequest(boost::system::error_code ec);
  void respond(Response response);
  /// A short text answer that closes the connection.
  Response textResponse(int status, const std::string& text) const;
  void onResponded(boost::system::error_code ec, bool keepAlive);
  void upgrade();
  void onUpgraded(boost::system::error_code ec);

  void readSome();
  void onRead(boost::system::error_code ec, size_t bytes);
  void closeSocket();

  const SessionServices& mServices;
  const WebGate& mGate;
  std::shared_ptr<boost::asio::ssl::context> mTlsContext;  ///< kept while the connection lives
  /// Without permessage-deflate, which the server never offered (frames are PNG, JPEG or video already): Beast then
  /// compiles no deflate code (5 s of the 80 s that WebSocketSession.cpp takes to compile).
  boost::beast::websocket::stream<Stream, false> mWs;
  boost::beast::flat_buffer mHttpBuffer;
  std::optional<boost::beast::http::request_parser<boost::beast::http::string_body>> mParser;
  Request mRequest;
  Response mResponse;
  std::shared_ptr<const TokenGrant> mGrant;  ///< of the accepted access token (accessGrant)
  bool mTlsOpen = !kTls;                     ///< the TLS handshake is done (always, in the clear)
  std::string mClearRefusal;                 ///< over TLS, the answer in the clear to a request in the clear
  bool mResponding = false;       ///< an HTTP response is being written
  bool mAnswered = false;         ///< an HTTP response was written: the connection is kept alive for the next
  bool mRefused = false;          ///< refused before the upgrade: requests are no longer answered
  bool mUpgrading = false;        ///< the WebSocket handshake is under way
  bool mUpgraded = false;         ///< the WebSocket is open: the Connection runs
  bool mWriting = false;          ///< a message is being written
  std::vector<uint8_t> mMessage;  ///< the message being read (its first mFill bytes so far)
  size_t mFill = 0;
  std::optional<size_t> mExpectedBytes;  ///< header plus the body its header announces, once the header is read
};

using PlainWebSocketSession = WebSocketSession<boost::beast::tcp_stream>;
using TlsWebSocketSession = WebSocketSession<boost::beast::ssl_stream<boost::beast::tcp_stream>>;

}  // namespace voxbrick::server
