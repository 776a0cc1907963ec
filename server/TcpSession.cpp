// Framing and socket I/O of one TCP connection.
#include "server/TcpSession.h"

#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

namespace voxbrick::server {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

/// Capacity of a session's read buffer kept between messages.
constexpr size_t kKeptBodyBytes = 64 << 10;

std::string tcpPeerOf(const tcp::socket& socket) {
  boost::system::error_code ec;
  const auto endpoint = socket.remote_endpoint(ec);
  return ec ? "?" : endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
}

}  // namespace

TcpSession::TcpSession(tcp::socket socket, const SessionServices& services, ConnectionId id)
    : AsioSession(socket.get_executor(), services, id, tcpPeerOf(socket)), mSocket(std::move(socket)) {}

void TcpSession::readMessage() {
  mHeaderFill = 0;
  readHeaderBytes();
}

void TcpSession::readHeaderBytes() {
  mSocket.async_read_some(
      asio::buffer(mHeaderBytes.data() + mHeaderFill, mHeaderBytes.size() - mHeaderFill),
      guarded(this, [](TcpSession& s, boost::system::error_code ec, size_t bytes) { s.onHeaderBytes(ec, bytes); }));
}

void TcpSession::onHeaderBytes(boost::system::error_code ec, size_t bytes) {
  if (ec) return mCore.readFailed();
  // The header is read as it comes, so the read deadline starts with the message's first byte.
  mCore.messageStarted();
  mHeaderFill += bytes;
  if (mHeaderFill < mHeaderBytes.size()) return readHeaderBytes();
  const std::optional<proto::Header> header = mCore.headerReceived(mHeaderBytes);
  if (!header) return;
  mBody.resize(header->bodyBytes);  // at most limits.maxBodyBytes, checked by decodeHeader
  asio::async_read(mSocket, asio::buffer(mBody),
                   guarded(this, [](TcpSession& s, boost::system::error_code e, size_t) { s.onBody(e); }));
}

void TcpSession::onBody(boost::system::error_code ec) {
  if (ec) return mCore.readFailed();
  mCore.bodyReceived(mBody);
  // Requests are small: the buffer is reused across them, and given back only after a large one.
  if (mBody.capacity() > kKeptBodyBytes) mBody = {};
  mBody.clear();
}

void TcpSession::write(std::span<const uint8_t> message) {
  asio::async_write(mSocket, asio::buffer(message.data(), message.size()),
                    guarded(this, [](TcpSession& s, boost::system::error_code ec, size_t bytes) {
                      s.mStats.bytesWritten(bytes);
                      s.mCore.written(!ec);
                    }));
}

void TcpSession::close() {
  boost::system::error_code ignored;
  mSocket.shutdown(tcp::socket::shutdown_both, ignored);
  mSocket.close(ignored);
}

}  // namespace voxbrick::server
