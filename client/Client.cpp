// Blocking client over Boost.Asio; the connect and every read and write are bounded by the session's timeout.
#include "client/Client.h"

#include <algorithm>
#include <cstdio>
#include <type_traits>
#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio.hpp>
#include <nlohmann/json.hpp>

namespace voxbrick::client {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

struct Client::Impl {
  asio::io_context io;
  tcp::socket socket{io};
  proto::Limits limits;
  std::string where;
  std::chrono::milliseconds timeout{0};

  /// Runs one asynchronous operation (`start` is given its completion handler) until it completes or the timeout
  /// passes. Blocking socket calls cannot do this: Asio waits for readiness with no limit when SO_RCVTIMEO fires, and
  /// a connect has no timeout at all. On time-out the socket is closed (the operation then ends aborted) and
  /// ConnectionError says what did not happen in time. Returns the operation's error code and byte count.
  template <typename Start>
  std::pair<boost::system::error_code, size_t> run(const std::string& what, Start&& start) {
    boost::system::error_code result = asio::error::would_block;
    size_t bytes = 0;
    start([&](const boost::system::error_code& ec, auto n) {
      result = ec;
      if constexpr (std::is_integral_v<decltype(n)>) bytes = size_t(n);
    });
    io.restart();
    io.run_for(timeout);
    if (result == asio::error::would_block) {
      boost::system::error_code ignored;
      socket.close(ignored);
      io.restart();
      io.run();  // the aborted operation's handler
      char seconds[32];
      std::snprintf(seconds, sizeof seconds, "%g", double(timeout.count()) / 1000);
      throw ConnectionError(what + " " + where + ": no answer within " + seconds + " s");
    }
    return {result, bytes};
  }
};

Client::Client(const std::string& host, int port, std::chrono::milliseconds timeout) : mImpl(std::make_unique<Impl>()) {
  mImpl->where = host + ":" + std::to_string(port);
  // Frames can be large: accept bodies up to the protocol's ceiling.
  mImpl->limits.maxBodyBytes = 1u << 30;
  mImpl->limits.maxStringBytes = 64u << 20;
  mImpl->timeout = timeout;
  tcp::resolver::results_type endpoints;
  try {
    tcp::resolver resolver(mImpl->io);
    endpoints = resolver.resolve(host, std::to_string(port));
  } catch (const boost::system::system_error& e) {
    throw ConnectionError("cannot connect to " + mImpl->where + ": " + e.code().message());
  }
  const boost::system::error_code ec =
      mImpl
          ->run("connecting to",
                [&](auto handler) {
                  asio::async_connect(
                      mImpl->socket, endpoints,
                      [handler](const boost::system::error_code& e, const tcp::endpoint&) { handler(e, 0); });
                })
          .first;
  if (ec) throw ConnectionError("cannot connect to " + mImpl->where + ": " + ec.message());
  mImpl->socket.set_option(tcp::no_delay(true));
}

Client::~Client() = default;

void Client::sendBytes(const std::vector<uint8_t>& bytes) {
  const boost::system::error_code ec =
      mImpl->run("sending to", [&](auto handler) { asio::async_write(mImpl->socket, asio::buffer(bytes), handler); })
          .first;
  if (ec) throw ConnectionError("sending to " + mImpl->where + ": " + ec.message());
}

uint32_t Client::send(const proto::Message& message) {
  const uint32_t id = mNextId++;
  sendBytes(proto::encode(message, id, mVersion));
  return id;
}

std::vector<uint8_t> Client::receiveBytes(size_t max) {
  std::vector<uint8_t> bytes(max);
  const auto [ec, n] =
      mImpl->run("reading from", [&](auto handler) { mImpl->socket.async_read_some(asio::buffer(bytes), handler); });
  bytes.resize(ec ? 0 : n);
  if (ec && ec != asio::error::eof) throw ConnectionError("reading from " + mImpl->where + ": " + ec.message());
  return bytes;
}

std::pair<uint32_t, proto::Message> Client::receive() {
  std::array<uint8_t, proto::kHeaderBytes> head{};
  auto readAll = [&](asio::mutable_buffer buffer) {
    return mImpl->run("reading from", [&](auto handler) { asio::async_read(mImpl->socket, buffer, handler); }).first;
  };
  boost::system::error_code ec = readAll(asio::buffer(head));
  if (ec)
    throw ConnectionError("reading from " + mImpl->where + ": " +
                          (ec == asio::error::eof ? std::string("the server closed the connection") : ec.message()));
  try {
    const proto::Header header = proto::decodeHeader(head, mImpl->limits);
    std::vector<uint8_t> body(header.bodyBytes);
    ec = readAll(asio::buffer(body));
    if (ec) throw ConnectionError("reading from " + mImpl->where + ": " + ec.message());
    return {header.requestId, proto::decodeBody(header, body, mImpl->limits)};
  } catch (const proto::ProtocolError& e) {
    throw ConnectionError(mImpl->where + " sent an undecodable message: " + e.what());
  }
}

bool Client::waitReadable(std::chrono::milliseconds wait) {
  boost::system::error_code ignored;
  if (mImpl->socket.available(ignored) > 0) return true;
  bool readable = false;
  asio::steady_timer timer(mImpl->io, wait);
  mImpl->socket.async_wait(tcp::socket::wait_read, [&](const boost::system::error_code& ec) {
    readable = !ec;
    timer.cancel();
  });
  timer.async_wait([&](const boost::system::error_code& ec) {
    if (!ec) mImpl->socket.cancel();  // nothing came in time: the wait ends, no byte read
  });
  mImpl->io.restart();
  mImpl->io.run();
  return readable;
}

proto::Message Client::call(const proto::Message& message) { return awaitReply(send(message)); }

proto::Message Client::awaitReply(uint32_t id) {
  for (;;) {
    auto [replyId, reply] = receive();
    if (const auto* error = std::get_if<proto::Error>(&reply)) {
      if (replyId == id || replyId == 0) throw ServerError(error->code, error->message);
      continue;  // an older request's error (e.g. Superseded)
    }
    if (replyId == id) return std::move(reply);
  }
}

template <typename T>
T expect(proto::Message reply, const char* what) {
  if (auto* m = std::get_if<T>(&reply)) return std::move(*m);
  throw ConnectionError(std::string("unexpected reply to ") + what + ": " +
                        proto::messageTypeName(proto::messageType(reply)));
}

proto::Capabilities Client::hello(const std::string& clientName, uint16_t maxVersion) {
  // Hello is written in the lowest version offered (PROTOCOL.md section 5); the session speaks the server's pick.
  mVersion = proto::kMinVersion;
  proto::Capabilities caps =
      expect<proto::Capabilities>(call(proto::Hello{proto::kMinVersion, maxVersion, clientName}), "Hello");
  if (caps.version < proto::kMinVersion || caps.version > maxVersion)
    throw ConnectionError(mImpl->where + " chose protocol version " + std::to_string(caps.version) +
                          ", outside the offered " + std::to_string(proto::kMinVersion) + ".." +
                          std::to_string(maxVersion));
  mVersion = caps.version;
  return caps;
}

std::vector<std::string> Client::listDatasets() {
  return expect<proto::DatasetList>(call(proto::ListDatasets{}), "ListDatasets").names;
}

proto::DatasetInfo Client::openDataset(const std::string& name) {
  return expect<proto::DatasetInfo>(call(proto::OpenDataset{name}), "OpenDataset");
}

proto::Frame Client::render(const std::string& sceneJson, proto::Encoding encoding,
                            const std::function<void(const proto::Frame&)>& onProvisional) {
  if (!proto::encodingInVersion(encoding, mVersion))
    throw std::invalid_argument(std::string("the ") + proto::encodingName(encoding) +
                                " encoding needs protocol version 2; the server speaks version " +
                                std::to_string(mVersion));
  const uint32_t id = send(proto::RenderRequest{encoding, sceneJson});
  for (proto::Frame frame = expect<proto::Frame>(awaitReply(id), "Render");;
       frame = expect<proto::Frame>(awaitReply(id), "Render")) {
    if (!isProvisional(frame)) return frame;
    if (onProvisional) onProvisional(frame);
  }
}

bool isProvisional(const proto::Frame& frame) {
  const nlohmann::json stats = nlohmann::json::parse(frame.statsJson, nullptr, false);
  return stats.is_object() && stats.value("provisional", false) == true;
}

std::string Client::stats() { return expect<proto::Stats>(call(proto::GetStats{}), "GetStats").json; }

void Client::goodbye() {
  try {
    send(proto::Goodbye{});
  } catch (const ConnectionError&) {
  }
  close();
}

void Client::close() {
  boost::system::error_code ignored;
  mImpl->socket.shutdown(tcp::socket::shutdown_both, ignored);
  mImpl->socket.close(ignored);
}

proto::Encoding encodingNamed(const std::string& name) {
  if (const auto encoding = proto::encodingFromShortName(name)) return *encoding;
  throw std::invalid_argument("'" + name + "' is not an encoding (raw, png, zstd, jpeg, vp8 or vp9)");
}

uint32_t frameMessageBytes(const proto::Frame& frame) {
  const uint64_t bytes = proto::kHeaderBytes + 4 + 4 + 1 + 4 + frame.statsJson.size() + 4 + frame.payload.size();
  return uint32_t(std::min<uint64_t>(bytes, UINT32_MAX));
}

void Client::frameReceived(uint32_t requestId, const proto::Frame& frame) {
  if (!proto::messageTypeInVersion(proto::MessageType::FrameReceived, mVersion)) return;
  sendBytes(proto::encode(proto::FrameReceived{frameMessageBytes(frame)}, requestId, mVersion));
}

std::pair<std::string, int> parseAddress(const std::string& text) {
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size())
    throw std::invalid_argument("'" + text + "' is not HOST:PORT; e.g. 127.0.0.1:7420");
  int port = 0;
  try {
    size_t used = 0;
    port = std::stoi(text.substr(colon + 1), &used);
    if (used != text.size() - colon - 1) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    throw std::invalid_argument("'" + text + "': port is not a number");
  }
  if (port < 1 || port > 65535) throw std::invalid_argument("'" + text + "': port out of range");
  return {text.substr(0, colon), port};
}

}  // namespace voxbrick::client
