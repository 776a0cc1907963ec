// HTTP, the upgrade of /ws, and one protocol message per WebSocket binary message, of one browser connection.
#include "server/WebSocketSession.h"

#include <chrono>
#include <string>

#include <spdlog/spdlog.h>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core/detect_ssl.hpp>
#include <boost/beast/http/read.hpp>
#include <boost/beast/http/write.hpp>
#include <boost/beast/websocket/rfc6455.hpp>
#include <boost/beast/websocket/ssl.hpp>

#include "server/TlsContext.h"

namespace voxbrick::server {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

constexpr size_t kRequestHeaderLimit = 8 << 10;  ///< bytes of an HTTP request's header; more is refused (431)
constexpr size_t kRequestBodyLimit = 4 << 10;    ///< bytes of an HTTP request's body (none is needed)
constexpr size_t kReadChunk = 64 << 10;          ///< the most one read of a message takes
constexpr size_t kKeptMessageBytes = 64 << 10;   ///< capacity of the read buffer kept between messages

std::string_view view(beast::string_view text) { return {text.data(), text.size()}; }

std::chrono::milliseconds milliseconds(double seconds) { return std::chrono::milliseconds(int64_t(seconds * 1000)); }

std::string webSocketPeerOf(const tcp::socket& socket, bool tls) {
  boost::system::error_code ec;
  const auto endpoint = socket.remote_endpoint(ec);
  return ec ? "?" : endpoint.address().to_string() + ":" + std::to_string(endpoint.port()) + (tls ? " (wss)" : " (ws)");
}

}  // namespace

template <class Stream>
WebSocketSession<Stream>::WebSocketSession(tcp::socket socket, const SessionServices& services, const WebGate& gate,
                                           ConnectionId id) requires(!kTls)
    : AsioSession(socket.get_executor(), services, id, webSocketPeerOf(socket, false), "ws"),
      mServices(services),
      mGate(gate),
      mWs(std::move(socket)),
      mHttpBuffer(kRequestHeaderLimit + kRequestBodyLimit) {}

template <class Stream>
WebSocketSession<Stream>::WebSocketSession(tcp::socket socket, std::shared_ptr<asio::ssl::context> tls,
                                           const SessionServices& services, const WebGate& gate,
                                           ConnectionId id) requires(kTls)
    : AsioSession(socket.get_executor(), services, id, webSocketPeerOf(socket, true), "wss"),
      mServices(services),
      mGate(gate),
      mTlsContext(std::move(tls)),
      mWs(std::move(socket), *mTlsContext),
      mHttpBuffer(kRequestHeaderLimit + kRequestBodyLimit) {}

template <class Stream>
void WebSocketSession<Stream>::start() {
  asio::post(mWs.get_executor(), guarded(this, [](WebSocketSession& s) {
               if constexpr (kTls)
                 s.detectTls();
               else
                 s.readRequest();
             }));
}

template <class Stream>
void WebSocketSession<Stream>::end(proto::Error error) {
  asio::post(mWs.get_executor(), guarded(this, [error = std::move(error)](WebSocketSession& s) {
               if (s.mUpgraded) return s.mCore.end(error);
               if (s.mCore.closed()) return;
               // Over TLS before the handshake no byte can reach the client: closed at once, at no handshake's cost.
               if (!s.mTlsOpen || s.mResponding || s.mUpgrading) return s.mCore.close();
               // Refused before the upgrade (too many connections, the server stopping): HTTP says why.
               spdlog::debug("{}: refused before the upgrade: {}", s.peer(), error.message);
               s.mRefused = true;
               s.respond(s.textResponse(503, "refused: " + error.message));
             }));
}

template <class Stream>
void WebSocketSession<Stream>::detectTls() {
  if constexpr (kTls) {
    // The handshake, like each request, must be complete within the Hello timeout: one trickled is closed then. Its
    // first bytes say whether it is one at all (a browser sent to http:// on this port is told so in the clear).
    beast::get_lowest_layer(mWs).expires_after(milliseconds(mServices.config.helloTimeoutS));
    beast::async_detect_ssl(
        beast::get_lowest_layer(mWs), mHttpBuffer,
        guarded(this, [](WebSocketSession& s, boost::system::error_code ec, bool tls) { s.onDetected(ec, tls); }));
  }
}

template <class Stream>
void WebSocketSession<Stream>::onDetected(boost::system::error_code ec, bool tls) {
  if constexpr (kTls) {
    if (mCore.closed()) return;
    if (ec == beast::error::timeout) {
      mServices.stats.add(ServerEvent::Timeout);
      spdlog::info("{}: closing: no TLS handshake within {} s", peer(), mServices.config.helloTimeoutS);
      return mCore.close();
    }
    if (ec) return mCore.close();
    if (!tls) {
      spdlog::info("{}: a request in the clear on the TLS port, answered in the clear and closed", peer());
      auto& socket = beast::get_lowest_layer(mWs).socket();
      boost::system::error_code ignored;
      std::vector<uint8_t> unread(std::min<size_t>(socket.available(ignored), 64 << 10));
      if (!unread.empty()) socket.read_some(asio::buffer(unread), ignored);
      const std::string text = "this port speaks TLS: open it with https:// (and wss:// for /ws)\n";
      mClearRefusal =
          "HTTP/1.1 400 Bad Request\r\nServer: voxbrick\r\nContent-Type: text/plain; charset=utf-8\r\n"
          "Content-Length: " +
          std::to_string(text.size()) + "\r\nConnection: close\r\n\r\n" + text;
      mResponding = true;
      beast::get_lowest_layer(mWs).expires_after(milliseconds(mServices.config.helloTimeoutS));
      asio::async_write(beast::get_lowest_layer(mWs), asio::buffer(mClearRefusal),
                        guarded(this, [](WebSocketSession& s, boost::system::error_code, size_t) {
                          s.mResponding = false;
                          s.mCore.close();
                        }));
      return;
    }
    mWs.next_layer().async_handshake(asio::ssl::stream_base::server, mHttpBuffer.data(),
                                     guarded(this, [](WebSocketSession& s, boost::system::error_code e, size_t used) {
                                       s.mHttpBuffer.consume(used);
                                       s.onHandshake(e);
                                     }));
  }
}

template <class Stream>
void WebSocketSession<Stream>::onHandshake(boost::system::error_code ec) {
  if (mCore.closed()) return;  // evicted or refused meanwhile
  if (ec) {
    if (ec == beast::error::timeout) {
      mServices.stats.add(ServerEvent::Timeout);
      spdlog::info("{}: closing: no TLS handshake within {} s", peer(), mServices.config.helloTimeoutS);
    } else {
      mServices.stats.refused(Refusal::Tls);
      spdlog::info("{}: TLS handshake failed: {}", peer(), tlsFailureText(ec));
      mCore.audit("refused", "TLS handshake: " + tlsFailureText(ec));
    }
    return mCore.close();
  }
  mTlsOpen = true;
  readRequest();
}

template <class Stream>
typename WebSocketSession<Stream>::Response WebSocketSession<Stream>::textResponse(int status,
                                                                                   const std::string& text) const {
  Response response(http::status(status), 11);
  response.set(http::field::server, "voxbrick");
  response.set(http::field::content_type, "text/plain; charset=utf-8");
  response.set(http::field::cache_control, "no-store");
  response.body().assign(text.begin(), text.end());
  response.body().push_back('\n');
  response.content_length(response.body().size());
  response.keep_alive(false);
  return response;
}

template <class Stream>
void WebSocketSession<Stream>::readRequest() {
  if (mCore.closed()) return;
  mParser.emplace();
  mParser->header_limit(kRequestHeaderLimit);
  mParser->body_limit(kRequestBodyLimit);
  // The request must arrive whole within the Hello timeout: a client that trickles it is closed then.
  beast::get_lowest_layer(mWs).expires_after(milliseconds(mServices.config.helloTimeoutS));
  http::async_read(mWs.next_layer(), mHttpBuffer, *mParser,
                   guarded(this, [](WebSocketSession& s, boost::system::error_code ec, size_t) { s.onRequest(ec); }));
}

template <class Stream>
void WebSocketSession<Stream>::onRequest(boost::system::error_code ec) {
  if (mCore.closed() || mRefused) return;
  if (ec == http::error::end_of_stream || ec == asio::error::eof || ec == asio::error::connection_reset)
    return mCore.close();
  if (ec == beast::error::timeout) {
    // A kept-alive connection that asks nothing more (a browser's, a Prometheus scrape's between scrapes) is closed
    // as idle, not counted as a request that failed to arrive in time.
    if (mAnswered && !mParser->got_some()) {
      spdlog::debug("{}: closing: kept alive, no further request within {} s", peer(), mServices.config.helloTimeoutS);
      return mCore.close();
    }
    mServices.stats.add(ServerEvent::Timeout);
    spdlog::info("{}: closing: no whole HTTP request within {} s", peer(), mServices.config.helloTimeoutS);
    return mCore.close();
  }
  if (ec) return refuseRequest(ec);
  mRequest = mParser->release();
  if (websocket::is_upgrade(mRequest)) return upgrade();

  const WebGate::Response r =
      mGate.respond(view(mRequest.method_string()), view(mRequest.target()), view(mRequest[http::field::if_none_match]),
                    view(mRequest[http::field::origin]), view(mRequest[http::field::authorization]));
  Response response(http::status(r.status), mRequest.version());
  response.set(http::field::server, "voxbrick");
  response.set(http::field::content_type, std::string(r.contentType));
  response.set("X-Content-Type-Options", "nosniff");
  // The page's URL may carry the access token: it is not to be passed on to other sites.
  response.set("Referrer-Policy", "no-referrer");
  if (r.status == 405) response.set(http::field::allow, "GET, HEAD");
  if (!r.allowOrigin.empty()) {
    response.set(http::field::access_control_allow_origin, r.allowOrigin);
    response.set(http::field::vary, "Origin");
  }
  if (!r.etag.empty()) {
    // The files change with the binary: a browser may keep them but asks each time (304 when unchanged).
    response.set(http::field::cache_control, "no-cache");
    response.set(http::field::etag, r.etag);
  } else {
    response.set(http::field::cache_control, "no-store");
  }
  const bool head = mRequest.method() == http::verb::head;
  if (!r.text.empty()) response.body().assign(r.text.begin(), r.text.end());
  if (!r.body.empty() && !r.notModified) response.body().assign(r.body.begin(), r.body.end());
  response.content_length(response.body().size());
  if (head || r.notModified) response.body().clear();
  response.keep_alive(mRequest.keep_alive());
  // The path only: the query may carry the access token, which is never logged.
  const std::string_view target = view(mRequest.target());
  spdlog::debug("{}: {} {} -> {}", peer(), view(mRequest.method_string()), target.substr(0, target.find('?')),
                r.status);
  respond(std::move(response));
}

template <class Stream>
void WebSocketSession<Stream>::refuseRequest(boost::system::error_code ec) {
  int status = 400;
  if (ec == http::error::header_limit || ec == http::error::buffer_overflow)
    status = 431;
  else if (ec == http::error::body_limit)
    status = 413;
  spdlog::info("{}: bad HTTP request ({}), closing", peer(), ec.message());
  respond(textResponse(status, "bad request: " + ec.message()));
}

template <class Stream>
void WebSocketSession<Stream>::respond(Response response) {
  mResponding = true;
  mResponse = std::move(response);
  const bool keepAlive = mResponse.keep_alive();
  beast::get_lowest_layer(mWs).expires_after(milliseconds(mServices.config.helloTimeoutS));
  http::async_write(mWs.next_layer(), mResponse,
                    guarded(this, [keepAlive](WebSocketSession& s, boost::system::error_code ec, size_t) {
                      s.onResponded(ec, keepAlive);
                    }));
}

template <class Stream>
void WebSocketSession<Stream>::onResponded(boost::system::error_code ec, bool keepAlive) {
  mResponding = false;
  if (mCore.closed()) return;
  if (ec || !keepAlive) return mCore.close();
  mAnswered = true;
  readRequest();
}

template <class Stream>
void WebSocketSession<Stream>::upgrade() {
  const auto origin = mRequest.find(http::field::origin);
  const std::optional<std::string> refusal = mGate.refuseUpgrade(
      view(mRequest.target()),
      origin == mRequest.end() ? std::nullopt : std::optional<std::string_view>(view(origin->value())),
      view(mRequest[http::field::host]));
  if (refusal) {
    mServices.stats.refused(Refusal::Forbidden);
    spdlog::info("{}: WebSocket upgrade refused: {}", peer(), *refusal);
    mCore.audit("refused", "WebSocket upgrade: " + *refusal);
    return respond(textResponse(403, "forbidden: " + *refusal));
  }
  mGrant = mGate.acceptedToken(view(mRequest.target()));
  // From here the Connection's deadlines rule: Beast's own run only for the opening and closing handshakes, and
  // it sends no pings of its own (the idle timeout is the Connection's).
  beast::get_lowest_layer(mWs).expires_never();
  websocket::stream_base::timeout timeouts{};
  timeouts.handshake_timeout = milliseconds(mServices.config.helloTimeoutS);
  timeouts.idle_timeout = websocket::stream_base::none();
  timeouts.keep_alive_pings = false;
  mWs.set_option(timeouts);
  mWs.set_option(websocket::stream_base::decorator(
      [](websocket::response_type& response) { response.set(http::field::server, "voxbrick"); }));
  // A frame announcing more than one whole protocol message may hold is refused before any of it is read.
  mWs.read_message_max(proto::kHeaderBytes + mServices.limits.maxBodyBytes);
  mWs.auto_fragment(false);
  mWs.binary(true);
  mUpgrading = true;
  mWs.async_accept(mRequest,
                   guarded(this, [](WebSocketSession& s, boost::system::error_code ec) { s.onUpgraded(ec); }));
}

template <class Stream>
void WebSocketSession<Stream>::onUpgraded(boost::system::error_code ec) {
  if (mCore.closed()) return;
  if (ec) {
    spdlog::info("{}: WebSocket handshake failed: {}", peer(), ec.message());
    return mCore.close();
  }
  mUpgraded = true;
  spdlog::debug("{}: WebSocket open", peer());
  if (mGrant) mCore.presented(mGrant);
  mCore.start();
}

template <class Stream>
void WebSocketSession<Stream>::readMessage() {
  // Requests are small: the buffer is reused across them, and given back only after a large one.
  if (mMessage.capacity() > kKeptMessageBytes) mMessage = {};
  mFill = 0;
  mExpectedBytes.reset();
  readSome();
}

template <class Stream>
void WebSocketSession<Stream>::readSome() {
  // The header first, alone, so that it is checked before any of the body is read; then the body it announces.
  const size_t want = std::min(kReadChunk, (mExpectedBytes ? *mExpectedBytes : proto::kHeaderBytes) - mFill);
  mMessage.resize(mFill + want);
  mWs.async_read_some(
      asio::buffer(mMessage.data() + mFill, want),
      guarded(this, [](WebSocketSession& s, boost::system::error_code ec, size_t bytes) { s.onRead(ec, bytes); }));
}

template <class Stream>
void WebSocketSession<Stream>::onRead(boost::system::error_code ec, size_t bytes) {
  if (ec) return mCore.readFailed();
  if (mCore.closed()) return;
  mCore.messageStarted();
  if (!mWs.got_binary())
    return mCore.refuse(proto::ErrorCode::Malformed,
                        "a text message: the protocol travels in binary messages, one protocol message each");
  mFill += bytes;
  if (!mExpectedBytes && mFill == proto::kHeaderBytes) {
    const std::optional<proto::Header> header =
        mCore.headerReceived(std::span<const uint8_t, proto::kHeaderBytes>(mMessage.data(), proto::kHeaderBytes));
    if (!header) return;  // answered, and closing
    mExpectedBytes = proto::kHeaderBytes + header->bodyBytes;
  }
  if (mWs.is_message_done()) {
    // Shorter than a header: Malformed, closing. A body shorter than its header announces: Malformed for that
    // request, and the session goes on (the next WebSocket message starts the next protocol message).
    if (!mExpectedBytes) return mCore.received(std::span<const uint8_t>(mMessage.data(), mFill));
    return mCore.bodyReceived(
        std::span<const uint8_t>(mMessage.data() + proto::kHeaderBytes, mFill - proto::kHeaderBytes));
  }
  if (mExpectedBytes && mFill == *mExpectedBytes)
    return mCore.refuse(proto::ErrorCode::Malformed,
                        "a WebSocket message longer than the protocol message its header announces (" +
                            std::to_string(*mExpectedBytes) + " bytes): each carries exactly one");
  readSome();
}

template <class Stream>
void WebSocketSession<Stream>::write(std::span<const uint8_t> message) {
  mWriting = true;
  mWs.async_write(asio::buffer(message.data(), message.size()),
                  guarded(this, [](WebSocketSession& s, boost::system::error_code ec, size_t bytes) {
                    s.mWriting = false;
                    s.mStats.bytesWritten(bytes);
                    s.mCore.written(!ec);
                  }));
}

template <class Stream>
void WebSocketSession<Stream>::close() {
  if (mUpgraded && !mWriting && mWs.is_open()) {
    // Every reply is written: the WebSocket closing handshake, bounded by Beast's handshake timeout, then the
    // socket. A session closed with a write in flight (its client does not read) is cut at once instead.
    mWs.async_close(websocket::close_code::normal,
                    guarded(this, [](WebSocketSession& s, boost::system::error_code) { s.closeSocket(); }));
    return;
  }
  closeSocket();
}

template <class Stream>
void WebSocketSession<Stream>::closeSocket() {
  boost::system::error_code ignored;
  tcp::socket& socket = beast::get_lowest_layer(mWs).socket();
  socket.shutdown(tcp::socket::shutdown_both, ignored);
  socket.close(ignored);
}

template class WebSocketSession<beast::tcp_stream>;
template class WebSocketSession<beast::ssl_stream<beast::tcp_stream>>;

}  // namespace voxbrick::server
