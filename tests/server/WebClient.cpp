// Beast clients of the browser transport for the server tests.
#include "WebClient.h"

#include <sys/socket.h>
#include <sys/time.h>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <optional>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>

#include "client/Client.h"

namespace voxbrick::test {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

std::string lower(std::string text) {
  for (char& c : text) c = char(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

/// Bounds every blocking read and write of `socket` by `timeout`.
void setTimeouts(tcp::socket& socket, std::chrono::milliseconds timeout) {
  timeval tv{};
  tv.tv_sec = long(timeout.count() / 1000);
  tv.tv_usec = long(timeout.count() % 1000) * 1000;
  ::setsockopt(socket.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(socket.native_handle(), SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
}

/// A client context trusting the CAs of `caFile`, checking the certificate is made out to 127.0.0.1.
std::unique_ptr<asio::ssl::context> clientContext(const std::string& caFile) {
  auto context = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_client);
  context->load_verify_file(caFile);
  context->set_verify_mode(asio::ssl::verify_peer);
  X509_VERIFY_PARAM_set1_ip_asc(SSL_CTX_get0_param(context->native_handle()), "127.0.0.1");
  return context;
}

/// One request on `stream` and its reply.
template <class Stream>
HttpReply exchange(Stream& stream, int port, const std::string& method, const std::string& target,
                   const std::vector<std::pair<std::string, std::string>>& headers) {
  http::request<http::string_body> request(http::string_to_verb(method), target, 11);
  request.method_string(method);
  request.set(http::field::host, "127.0.0.1:" + std::to_string(port));
  for (const auto& [name, value] : headers) request.set(name, value);
  request.prepare_payload();
  http::write(stream, request);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.skip(method == "HEAD");
  http::read(stream, buffer, parser);
  HttpReply reply;
  reply.status = int(parser.get().result_int());
  for (const auto& field : parser.get())
    reply.headers[lower(std::string(field.name_string()))] = std::string(field.value());
  reply.body = parser.get().body();
  return reply;
}

}  // namespace

HttpReply httpRequest(int port, const std::string& method, const std::string& target,
                      const std::vector<std::pair<std::string, std::string>>& headers) {
  asio::io_context io;
  tcp::socket socket(io);
  socket.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), uint16_t(port)));
  setTimeouts(socket, std::chrono::seconds(20));
  return exchange(socket, port, method, target, headers);
}

HttpReply httpsRequest(int port, const std::string& caFile, const std::string& method, const std::string& target) {
  asio::io_context io;
  const auto context = clientContext(caFile);
  asio::ssl::stream<tcp::socket> stream(io, *context);
  stream.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), uint16_t(port)));
  setTimeouts(stream.next_layer(), std::chrono::seconds(20));
  stream.handshake(asio::ssl::stream_base::client);
  return exchange(stream, port, method, target, {});
}

struct WebSocketClient::Impl {
  asio::io_context io;
  std::unique_ptr<asio::ssl::context> tls;
  std::optional<websocket::stream<tcp::socket>> ws;                      ///< ws://
  std::optional<websocket::stream<asio::ssl::stream<tcp::socket>>> wss;  ///< wss://

  template <typename F>
  auto with(F&& f) {
    if (wss) return f(*wss);
    return f(*ws);
  }
};

WebSocketClient::WebSocketClient(int port, const std::string& target, const std::string& origin,
                                 std::chrono::milliseconds timeout, const std::string& caFile)
    : mImpl(std::make_unique<Impl>()) {
  if (caFile.empty()) {
    mImpl->ws.emplace(mImpl->io);
  } else {
    mImpl->tls = clientContext(caFile);
    mImpl->wss.emplace(mImpl->io, *mImpl->tls);
  }
  tcp::socket& socket = mImpl->ws ? beast::get_lowest_layer(*mImpl->ws) : beast::get_lowest_layer(*mImpl->wss);
  socket.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), uint16_t(port)));
  setTimeouts(socket, timeout);
  if (mImpl->wss) mImpl->wss->next_layer().handshake(asio::ssl::stream_base::client);
  mImpl->with([&](auto& ws) {
    ws.set_option(websocket::stream_base::decorator([origin](websocket::request_type& request) {
      if (!origin.empty()) request.set(http::field::origin, origin);
    }));
    // Asynchronous, since Boost 1.74's synchronous handshake keeps a refusal's response to itself.
    websocket::response_type response;
    boost::system::error_code ec;
    ws.async_handshake(response, "127.0.0.1:" + std::to_string(port), target,
                       [&ec](boost::system::error_code e) { ec = e; });
    mImpl->io.run();
    mImpl->io.restart();
    if (ec == websocket::error::upgrade_declined)
      throw UpgradeRefused(int(response.result_int()), std::string(response.body()));
    if (ec) throw client::ConnectionError("WebSocket handshake: " + ec.message());
    ws.binary(true);
    ws.read_message_max(0);  // frames may exceed Beast's default limit
  });
}

WebSocketClient::~WebSocketClient() {
  boost::system::error_code ignored;
  mImpl->with([&](auto& ws) { beast::get_lowest_layer(ws).close(ignored); });
}

uint32_t WebSocketClient::send(const proto::Message& message) {
  const uint32_t id = mNextId++;
  const std::vector<uint8_t> bytes = proto::encode(message, id);
  sendRaw(bytes, true);
  return id;
}

void WebSocketClient::sendRaw(std::span<const uint8_t> bytes, bool binary) {
  try {
    mImpl->with([&](auto& ws) {
      ws.binary(binary);
      ws.write(asio::buffer(bytes.data(), bytes.size()));
    });
  } catch (const boost::system::system_error& e) {
    throw client::ConnectionError(std::string("write: ") + e.what());
  }
}

std::pair<uint32_t, proto::Message> WebSocketClient::receive() {
  beast::flat_buffer buffer;
  try {
    mImpl->with([&](auto& ws) { ws.read(buffer); });
  } catch (const boost::system::system_error& e) {
    throw client::ConnectionError(std::string("closed or failed: ") + e.what());
  }
  const auto data = buffer.data();
  const std::span<const uint8_t> bytes(static_cast<const uint8_t*>(data.data()), data.size());
  if (bytes.size() < proto::kHeaderBytes) throw client::ConnectionError("a message shorter than a header");
  proto::Limits limits;
  limits.maxBodyBytes = UINT32_MAX;
  const proto::Header header = proto::decodeHeader(bytes.first<proto::kHeaderBytes>(), limits);
  return {header.requestId, proto::decodeBody(header, bytes.subspan(proto::kHeaderBytes), limits)};
}

std::vector<proto::ErrorCode> WebSocketClient::errorsUntilClosed() {
  std::vector<proto::ErrorCode> codes;
  try {
    for (;;) {
      auto [id, message] = receive();
      if (const auto* e = std::get_if<proto::Error>(&message)) codes.push_back(e->code);
    }
  } catch (const client::ConnectionError&) {
  }
  return codes;
}

proto::Message WebSocketClient::call(const proto::Message& message) {
  const uint32_t id = send(message);
  for (;;) {
    auto [replyId, reply] = receive();
    if (replyId != id) continue;  // a late reply to an earlier request
    if (const auto* e = std::get_if<proto::Error>(&reply)) throw client::ServerError(e->code, e->message);
    return reply;
  }
}

proto::Capabilities WebSocketClient::hello(const std::string& clientName) {
  return std::get<proto::Capabilities>(call(proto::Hello{1, 1, clientName}));
}

std::vector<std::string> WebSocketClient::listDatasets() {
  return std::get<proto::DatasetList>(call(proto::ListDatasets{})).names;
}

proto::DatasetInfo WebSocketClient::openDataset(const std::string& name) {
  return std::get<proto::DatasetInfo>(call(proto::OpenDataset{name}));
}

proto::Frame WebSocketClient::render(const std::string& sceneJson, proto::Encoding encoding) {
  return std::get<proto::Frame>(call(proto::RenderRequest{encoding, sceneJson}));
}

std::string WebSocketClient::stats() { return std::get<proto::Stats>(call(proto::GetStats{})).json; }

}  // namespace voxbrick::test
