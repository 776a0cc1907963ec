// Sockets for hostile-client tests, over TCP or over a WebSocket framed by hand, in the clear or inside TLS.
#include "RawSocket.h"

#include <openssl/err.h>
#include <openssl/ssl.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>

namespace voxbrick::test {

namespace {

/// The client side of every test's TLS: TLS 1.2 or later, no certificate checked.
SSL_CTX* clientContext() {
  static SSL_CTX* context = [] {
    // OpenSSL writes with write(2), which raises SIGPIPE on a connection the server closed: the plain sockets send
    // with MSG_NOSIGNAL, and the TLS ones see the failed write as this process ignoring the signal.
    std::signal(SIGPIPE, SIG_IGN);
    SSL_CTX* c = SSL_CTX_new(TLS_client_method());
    if (!c) throw std::runtime_error("SSL_CTX_new failed");
    SSL_CTX_set_min_proto_version(c, TLS1_2_VERSION);
    SSL_CTX_set_verify(c, SSL_VERIFY_NONE, nullptr);
    return c;
  }();
  return context;
}

}  // namespace

RawSocket::RawSocket(int port, Framing framing, const std::string& target, bool tls) : mFraming(framing) {
  mFd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (mFd < 0) throw std::runtime_error("socket: " + std::to_string(errno));
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(uint16_t(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(mFd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    ::close(mFd);
    throw std::runtime_error("connect to port " + std::to_string(port) + ": errno " + std::to_string(errno));
  }
  if (tls && !handshake()) {
    mClosed = true;
    return;
  }
  if (framing == Framing::WebSocket) upgrade(port, target);
}

bool RawSocket::handshake() {
  mSsl = SSL_new(clientContext());
  if (!mSsl) throw std::runtime_error("SSL_new failed");
  SSL_set_mode(mSsl, SSL_MODE_ENABLE_PARTIAL_WRITE | SSL_MODE_ACCEPT_MOVING_WRITE_BUFFER);
  SSL_set_fd(mSsl, mFd);
  const timeval limit{10, 0};
  ::setsockopt(mFd, SOL_SOCKET, SO_RCVTIMEO, &limit, sizeof limit);
  ::setsockopt(mFd, SOL_SOCKET, SO_SNDTIMEO, &limit, sizeof limit);
  const bool done = SSL_connect(mSsl) == 1;
  ERR_clear_error();
  // From here on every read and write polls: sendSome must not block, and a read waits as long as its caller says.
  ::fcntl(mFd, F_SETFL, ::fcntl(mFd, F_GETFL) | O_NONBLOCK);
  return done;
}

long RawSocket::tlsWrite(std::span<const uint8_t> bytes) {
  if (bytes.empty()) return 0;
  const int n = SSL_write(mSsl, bytes.data(), int(std::min<size_t>(bytes.size(), 1 << 30)));
  if (n > 0) return n;
  const int error = SSL_get_error(mSsl, n);
  ERR_clear_error();
  return error == SSL_ERROR_WANT_WRITE || error == SSL_ERROR_WANT_READ ? 0 : -1;
}

void RawSocket::upgrade(int port, const std::string& target) {
  const std::string request = "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                              "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                              "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
  if (!sendAll(std::vector<uint8_t>(request.begin(), request.end()))) {
    mClosed = true;
    return;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  const std::string end = "\r\n\r\n";
  auto headerEnd = mInput.end();
  while ((headerEnd = std::search(mInput.begin(), mInput.end(), end.begin(), end.end())) == mInput.end()) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) throw std::runtime_error("no reply to the WebSocket upgrade within 10 s");
    if (!fill(left)) return;  // closed without a reply
  }
  const std::string head(mInput.begin(), headerEnd);
  mInput.erase(mInput.begin(), headerEnd + long(end.size()));
  const int status = head.size() > 12 ? std::atoi(head.c_str() + 9) : 0;
  if (status == 101) return;
  // Refused: the body (Content-Length bytes, or what comes before the close) says why.
  mRefusedStatus = status;
  while (fill(std::chrono::milliseconds(1000))) {
  }
  mRefusedBody.assign(mInput.begin(), mInput.end());
  mInput.clear();
  mClosed = true;
}

std::vector<uint8_t> RawSocket::webSocketFrame(std::span<const uint8_t> payload, int opcode, bool final) {
  std::vector<uint8_t> out;
  out.push_back(uint8_t((final ? 0x80 : 0) | opcode));
  const uint64_t n = payload.size();
  if (n < 126) {
    out.push_back(uint8_t(0x80 | n));
  } else if (n < 65536) {
    out.push_back(0x80 | 126);
    out.push_back(uint8_t(n >> 8));
    out.push_back(uint8_t(n));
  } else {
    out.push_back(0x80 | 127);
    for (int shift = 56; shift >= 0; shift -= 8) out.push_back(uint8_t(n >> shift));
  }
  static std::mt19937 random(7);
  const uint8_t mask[4] = {uint8_t(random()), uint8_t(random()), uint8_t(random()), uint8_t(random())};
  out.insert(out.end(), mask, mask + 4);
  for (size_t i = 0; i < payload.size(); ++i) out.push_back(payload[i] ^ mask[i % 4]);
  return out;
}

std::vector<uint8_t> RawSocket::frameStart(const std::vector<uint8_t>& first) const {
  return mFraming == Framing::WebSocket ? webSocketFrame(first, 2, false) : first;
}

std::vector<uint8_t> RawSocket::frame(const std::vector<uint8_t>& message) const {
  return mFraming == Framing::WebSocket ? webSocketFrame(message, 2, true) : message;
}

RawSocket::~RawSocket() {
  if (mSsl) SSL_free(mSsl);
  if (mFd >= 0) ::close(mFd);
}

bool RawSocket::sendAll(const std::vector<uint8_t>& bytes) {
  if (mSsl) {
    for (size_t sent = 0; sent < bytes.size();) {
      const long n = tlsWrite(std::span(bytes).subspan(sent));
      if (n < 0) return false;
      if (n == 0) {
        pollfd p{mFd, POLLOUT | POLLIN, 0};
        if (::poll(&p, 1, 10000) <= 0) return false;  // nothing moved for 10 s
      }
      sent += size_t(n);
    }
    return true;
  }
  size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(mFd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    sent += size_t(n);
  }
  return true;
}

long RawSocket::sendSome(std::span<const uint8_t> bytes) {
  if (mSsl) return tlsWrite(bytes);
  const ssize_t n = ::send(mFd, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  if (n >= 0) return long(n);
  return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR ? 0 : -1;
}

bool RawSocket::fill(std::chrono::milliseconds timeout) {
  if (mClosed) return false;
  if (mSsl) {
    if (SSL_pending(mSsl) == 0) {
      pollfd p{mFd, POLLIN, 0};
      if (::poll(&p, 1, int(timeout.count())) <= 0) return true;  // nothing yet
    }
    uint8_t buffer[65536];
    const int n = SSL_read(mSsl, buffer, sizeof buffer);
    if (n > 0) {
      mInput.insert(mInput.end(), buffer, buffer + n);
      return true;
    }
    const int error = SSL_get_error(mSsl, n);
    ERR_clear_error();
    if (error == SSL_ERROR_WANT_READ || error == SSL_ERROR_WANT_WRITE) return true;  // a record not whole yet
    mClosed = true;  // closed (close_notify or not), or reset
    return false;
  }
  pollfd p{mFd, POLLIN, 0};
  const int ready = ::poll(&p, 1, int(timeout.count()));
  if (ready <= 0) return true;  // nothing yet
  uint8_t buffer[65536];
  const ssize_t n = ::recv(mFd, buffer, sizeof buffer, 0);
  if (n < 0 && (errno == EINTR || errno == EAGAIN)) return true;
  if (n <= 0) {  // closed, or reset
    mClosed = true;
    return false;
  }
  mInput.insert(mInput.end(), buffer, buffer + n);
  return true;
}

std::optional<std::vector<uint8_t>> RawSocket::takeWebSocketMessage() {
  for (;;) {
    if (mInput.size() < 2) return std::nullopt;
    const int opcode = mInput[0] & 15;
    const bool final = (mInput[0] & 0x80) != 0, masked = (mInput[1] & 0x80) != 0;
    uint64_t n = mInput[1] & 127;
    size_t at = 2;
    if (n >= 126) {
      const size_t bytes = n == 126 ? 2 : 8;
      if (mInput.size() < at + bytes) return std::nullopt;
      n = 0;
      for (size_t i = 0; i < bytes; ++i) n = (n << 8) | mInput[at + i];
      at += bytes;
    }
    uint8_t mask[4] = {0, 0, 0, 0};
    if (masked) {
      if (mInput.size() < at + 4) return std::nullopt;
      std::copy(mInput.begin() + long(at), mInput.begin() + long(at + 4), mask);
      at += 4;
    }
    if (mInput.size() < at + n) return std::nullopt;
    std::vector<uint8_t> payload(mInput.begin() + long(at), mInput.begin() + long(at + n));
    for (size_t i = 0; i < payload.size(); ++i) payload[i] ^= mask[i % 4];
    mInput.erase(mInput.begin(), mInput.begin() + long(at + n));
    if (opcode == 8) {  // the server closes: nothing more will come
      mCloseCode = payload.size() >= 2 ? (payload[0] << 8) | payload[1] : 1005;
      mClosed = true;
      mInput.clear();
      return std::nullopt;
    }
    if (opcode >= 8) continue;  // ping, pong
    mFragments.insert(mFragments.end(), payload.begin(), payload.end());
    if (final) return std::exchange(mFragments, {});
  }
}

std::optional<std::pair<uint32_t, proto::Message>> RawSocket::take() {
  if (mFraming == Framing::None) return std::nullopt;
  proto::Limits limits;
  limits.maxBodyBytes = UINT32_MAX;
  if (mFraming == Framing::WebSocket) {
    const auto message = takeWebSocketMessage();
    if (!message || message->size() < proto::kHeaderBytes) return std::nullopt;
    const proto::Header header = proto::decodeHeader(
        std::span<const uint8_t, proto::kHeaderBytes>(message->data(), proto::kHeaderBytes), limits);
    mLastHeader = header;
    return std::make_pair(header.requestId,
                          proto::decodeBody(header, std::span(*message).subspan(proto::kHeaderBytes), limits));
  }
  if (mInput.size() < proto::kHeaderBytes) return std::nullopt;
  const proto::Header header =
      proto::decodeHeader(std::span<const uint8_t, proto::kHeaderBytes>(mInput.data(), proto::kHeaderBytes), limits);
  if (mInput.size() < proto::kHeaderBytes + header.bodyBytes) return std::nullopt;
  const std::vector<uint8_t> body(mInput.begin() + proto::kHeaderBytes,
                                  mInput.begin() + long(proto::kHeaderBytes + header.bodyBytes));
  mInput.erase(mInput.begin(), mInput.begin() + long(proto::kHeaderBytes + header.bodyBytes));
  mLastHeader = header;
  return std::make_pair(header.requestId, proto::decodeBody(header, body, limits));
}

std::optional<proto::Message> RawSocket::receive(std::chrono::milliseconds timeout) {
  auto message = receiveWithId(timeout);
  if (!message) return std::nullopt;
  return std::move(message->second);
}

std::optional<std::pair<uint32_t, proto::Message>> RawSocket::receiveWithId(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (auto message = take()) return message;
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0 || mClosed || !fill(left)) return std::nullopt;
  }
}

bool RawSocket::waitClosed(std::chrono::milliseconds timeout, std::vector<proto::ErrorCode>* codes) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    while (auto message = take())
      if (const auto* e = std::get_if<proto::Error>(&message->second); e && codes) codes->push_back(e->code);
    if (mClosed) return true;
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    fill(left);
  }
}

}  // namespace voxbrick::test
