// The TCP transport of one client connection: message framing (the fixed header, then as many body bytes as it
// announces) and socket I/O, in the clear or through TLS, nothing else. The rules (deadlines, admission, the reply
// queue and its back-pressure, the output budget) are the Connection's, which it reports its reads and writes to; the
// strand and timers are AsioSession's. Over TLS the handshake comes first, within the connection's Hello deadline (a
// connection is pending, and may be evicted, until its Hello, handshake included).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/asio/ssl/stream.hpp>

#include "server/AsioSession.h"

namespace voxbrick::server {

class TcpSession final : public AsioSession {
 public:
  /// `socket` must be connected and bound to a strand executor; `id` is the server's number for it. With `tls`, the
  /// connection speaks TLS with that context (which it keeps).
  TcpSession(boost::asio::ip::tcp::socket socket, const SessionServices& services, ConnectionId id,
             std::shared_ptr<boost::asio::ssl::context> tls = nullptr);

  /// Before its TLS handshake is done nothing can be written to a connection: it is closed without the Error.
  void end(proto::Error error) override;
  void readMessage() override;
  void write(std::span<const uint8_t> message) override;
  void close() override;

 private:
  /// Where a TLS connection is: its first byte not seen yet, its handshake under way, open; or a client that spoke
  /// the protocol in the clear to the TLS port, answered in the clear.
  enum class Tls { Off, Waiting, Handshaking, Open, ClearRefusal };

  /// Runs `f` on the stream the protocol travels on: the TLS stream, or the socket itself.
  template <typename F>
  void withStream(F&& f) {
    if (mTls == Tls::Open)
      f(*mTlsStream);
    else
      f(mSocket);
  }
  void peekFirstByte();
  void onFirstByte(boost::system::error_code ec, size_t bytes);
  void onHandshake(boost::system::error_code ec);
  void readHeaderBytes();
  void onHeaderBytes(boost::system::error_code ec, size_t bytes);
  void onBody(boost::system::error_code ec);

  boost::asio::ip::tcp::socket mSocket;
  std::shared_ptr<boost::asio::ssl::context> mTlsContext;
  std::optional<boost::asio::ssl::stream<boost::asio::ip::tcp::socket&>> mTlsStream;
  Tls mTls = Tls::Off;
  uint8_t mFirstByte = 0;
  std::array<uint8_t, proto::kHeaderBytes> mHeaderBytes{};
  size_t mHeaderFill = 0;  ///< bytes of mHeaderBytes read
  std::vector<uint8_t> mBody;
};

}  // namespace voxbrick::server
