// The TCP transport of one client connection: message framing (the fixed header, then as many body bytes as it
// announces) and socket I/O, nothing else. The rules (deadlines, admission, the reply queue and its back-pressure,
// the output budget) are the Connection's, which it reports its reads and writes to; the strand and timers are
// AsioSession's.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/ip/tcp.hpp>

#include "server/AsioSession.h"

namespace voxbrick::server {

class TcpSession final : public AsioSession {
 public:
  /// `socket` must be connected and bound to a strand executor; `id` is the server's number for it.
  TcpSession(boost::asio::ip::tcp::socket socket, const SessionServices& services, ConnectionId id);

  void readMessage() override;
  void write(std::span<const uint8_t> message) override;
  void close() override;

 private:
  void readHeaderBytes();
  void onHeaderBytes(boost::system::error_code ec, size_t bytes);
  void onBody(boost::system::error_code ec);

  boost::asio::ip::tcp::socket mSocket;
  std::array<uint8_t, proto::kHeaderBytes> mHeaderBytes{};
  size_t mHeaderFill = 0;  ///< bytes of mHeaderBytes read
  std::vector<uint8_t> mBody;
};

}  // namespace voxbrick::server
