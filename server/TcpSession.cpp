// Framing and socket I/O of one TCP connection, in the clear or through TLS.
#include "server/TcpSession.h"

#include <spdlog/spdlog.h>
#include <boost/asio/post.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

#include "server/ErrorReply.h"
#include "server/TlsContext.h"

namespace voxbrick::server {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

/// Capacity of a session's read buffer kept between messages.
constexpr size_t kKeptBodyBytes = 64 << 10;
/// The first byte of a TLS handshake record (RFC 8446, 5.1: ContentType handshake).
constexpr uint8_t kTlsHandshakeRecord = 0x16;
/// The first byte of every protocol message ("VXBK").
constexpr uint8_t kProtocolFirstByte = 'V';

std::string tcpPeerOf(const tcp::socket& socket, bool tls) {
  boost::system::error_code ec;
  const auto endpoint = socket.remote_endpoint(ec);
  return ec ? "?" : endpoint.address().to_string() + ":" + std::to_string(endpoint.port()) + (tls ? " (tls)" : "");
}

}  // namespace

TcpSession::TcpSession(tcp::socket socket, const SessionServices& services, ConnectionId id,
                       std::shared_ptr<asio::ssl::context> tls)
    : AsioSession(socket.get_executor(), services, id, tcpPeerOf(socket, tls != nullptr), tls ? "tls" : "tcp"),
      mSocket(std::move(socket)),
      mTlsContext(std::move(tls)) {
  if (mTlsContext) {
    mTlsStream.emplace(mSocket, *mTlsContext);
    mTls = Tls::Waiting;
  }
}

void TcpSession::end(proto::Error error) {
  asio::post(mSocket.get_executor(), guarded(this, [error = std::move(error)](TcpSession& s) {
               // Before the handshake no byte can reach the client: a refused TLS connection is closed at once, and
               // costs the server no handshake.
               if (s.mTls == Tls::Waiting || s.mTls == Tls::Handshaking) return s.mCore.close();
               s.mCore.end(error);
             }));
}

void TcpSession::readMessage() {
  if (mTls == Tls::Waiting) return peekFirstByte();
  mHeaderFill = 0;
  readHeaderBytes();
}

void TcpSession::peekFirstByte() {
  // The first byte says whether the client speaks TLS: a protocol message in the clear is answered in the clear, so
  // that a client without TLS learns why, instead of a handshake failing on its bytes.
  mSocket.async_receive(
      asio::buffer(&mFirstByte, 1), tcp::socket::message_peek,
      guarded(this, [](TcpSession& s, boost::system::error_code ec, size_t bytes) { s.onFirstByte(ec, bytes); }));
}

void TcpSession::onFirstByte(boost::system::error_code ec, size_t bytes) {
  if (mCore.closed()) return;
  if (ec || bytes == 0) return mCore.readFailed();
  if (mFirstByte == kProtocolFirstByte) {
    mTls = Tls::ClearRefusal;
    // What arrived is taken first: closing a socket with unread bytes resets the connection, and the client could
    // lose the answer.
    boost::system::error_code ignored;
    std::vector<uint8_t> unread(std::min<size_t>(mSocket.available(ignored), 64 << 10));
    if (!unread.empty()) mSocket.read_some(asio::buffer(unread), ignored);
    spdlog::info("{}: a protocol message in the clear on the TLS port, refused", peer());
    return mCore.refuse(proto::ErrorCode::UnexpectedMessage,
                        "this server speaks TLS: connect with TLS (voxbrick request --tls, the client's TLS "
                        "option), then say Hello");
  }
  if (mFirstByte != kTlsHandshakeRecord) {
    spdlog::info("{}: closing: neither a TLS handshake nor a protocol message (first byte 0x{:02x})", peer(),
                 mFirstByte);
    return mCore.readFailed();
  }
  mTls = Tls::Handshaking;
  mTlsStream->async_handshake(asio::ssl::stream_base::server,
                              guarded(this, [](TcpSession& s, boost::system::error_code e) { s.onHandshake(e); }));
}

void TcpSession::onHandshake(boost::system::error_code ec) {
  if (mCore.closed()) return;  // the Hello deadline passed, or it was evicted: closed meanwhile
  if (ec) {
    mStats.refused(Refusal::Tls);
    spdlog::info("{}: TLS handshake failed: {}", peer(), tlsFailureText(ec));
    mCore.audit("refused", "TLS handshake: " + tlsFailureText(ec));
    return mCore.readFailed();
  }
  mTls = Tls::Open;
  spdlog::debug("{}: TLS open ({}, {})", peer(), SSL_get_version(mTlsStream->native_handle()),
                SSL_get_cipher_name(mTlsStream->native_handle()));
  readMessage();
}

void TcpSession::readHeaderBytes() {
  withStream([this](auto& stream) {
    stream.async_read_some(
        asio::buffer(mHeaderBytes.data() + mHeaderFill, mHeaderBytes.size() - mHeaderFill),
        guarded(this, [](TcpSession& s, boost::system::error_code ec, size_t bytes) { s.onHeaderBytes(ec, bytes); }));
  });
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
  withStream([this](auto& stream) {
    asio::async_read(stream, asio::buffer(mBody),
                     guarded(this, [](TcpSession& s, boost::system::error_code e, size_t) { s.onBody(e); }));
  });
}

void TcpSession::onBody(boost::system::error_code ec) {
  if (ec) return mCore.readFailed();
  mCore.bodyReceived(mBody);
  // Requests are small: the buffer is reused across them, and given back only after a large one.
  if (mBody.capacity() > kKeptBodyBytes) mBody = {};
  mBody.clear();
}

void TcpSession::write(std::span<const uint8_t> message) {
  if (mTls == Tls::Waiting || mTls == Tls::Handshaking) {
    // Nothing can be written before the handshake (an Error for a Hello deadline that passed during it): the write
    // fails, which closes the connection.
    asio::post(mSocket.get_executor(), guarded(this, [](TcpSession& s) { s.mCore.written(false); }));
    return;
  }
  withStream([this, message](auto& stream) {
    asio::async_write(stream, asio::buffer(message.data(), message.size()),
                      guarded(this, [](TcpSession& s, boost::system::error_code ec, size_t bytes) {
                        s.mStats.bytesWritten(bytes);
                        s.mCore.written(!ec);
                      }));
  });
}

void TcpSession::close() {
  // A TLS connection is cut without its closing alert: the client has its replies, or is not to get any more.
  boost::system::error_code ignored;
  mSocket.shutdown(tcp::socket::shutdown_both, ignored);
  mSocket.close(ignored);
}

}  // namespace voxbrick::server
