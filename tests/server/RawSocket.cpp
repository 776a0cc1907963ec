// Plain sockets for hostile-client tests.
#include "RawSocket.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <stdexcept>
#include <string>

namespace voxbrick::test {

RawSocket::RawSocket(int port) {
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
}

RawSocket::~RawSocket() {
  if (mFd >= 0) ::close(mFd);
}

bool RawSocket::sendAll(const std::vector<uint8_t>& bytes) {
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
  const ssize_t n = ::send(mFd, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  if (n >= 0) return long(n);
  return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR ? 0 : -1;
}

bool RawSocket::fill(std::chrono::milliseconds timeout) {
  if (mClosed) return false;
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

std::optional<proto::Message> RawSocket::take() {
  if (mInput.size() < proto::kHeaderBytes) return std::nullopt;
  proto::Limits limits;
  const proto::Header header =
      proto::decodeHeader(std::span<const uint8_t, proto::kHeaderBytes>(mInput.data(), proto::kHeaderBytes), limits);
  if (mInput.size() < proto::kHeaderBytes + header.bodyBytes) return std::nullopt;
  const std::vector<uint8_t> body(mInput.begin() + proto::kHeaderBytes,
                                  mInput.begin() + long(proto::kHeaderBytes + header.bodyBytes));
  mInput.erase(mInput.begin(), mInput.begin() + long(proto::kHeaderBytes + header.bodyBytes));
  mLastHeader = header;
  return proto::decodeBody(header, body, limits);
}

std::optional<proto::Message> RawSocket::receive(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (auto message = take()) return message;
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0 || !fill(left)) return std::nullopt;
  }
}

bool RawSocket::waitClosed(std::chrono::milliseconds timeout, std::vector<proto::ErrorCode>* codes) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    while (auto message = take())
      if (const auto* e = std::get_if<proto::Error>(&*message); e && codes) codes->push_back(e->code);
    if (mClosed) return true;
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    fill(left);
  }
}

}  // namespace voxbrick::test
