// Blocking client over Boost.Asio, in the clear or over TLS; the connect, the handshake and every read and write are
// bounded by the session's timeout.
#include "client/Client.h"

#include <algorithm>
#include <cstdio>
#include <optional>
#include <type_traits>
#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>
#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <nlohmann/json.hpp>

namespace voxbrick::client {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

namespace {

/// OpenSSL's queued errors as one text (the queue emptied), or `fallback` when there are none.
std::string openSslErrors(const std::string& fallback) {
  std::string out;
  while (const unsigned long code = ERR_get_error()) {
    const char* reason = ERR_reason_error_string(code);
    if (!out.empty()) out += "; ";
    out += reason ? reason : "error " + std::to_string(code);
  }
  return out.empty() ? fallback : out;
}

/// The client's TLS context: TLS 1.2 or later, the server verified against `options`' CAs (or the system's) unless
/// insecure, the client's own certificate if given. Throws ConnectionError naming a file that cannot be used.
std::unique_ptr<asio::ssl::context> clientContext(const TlsOptions& options) {
  auto context = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_client);
  SSL_CTX* ctx = context->native_handle();
  ERR_clear_error();
  SSL_CTX_set_min_proto_version(ctx, TLS1_2_VERSION);
  if (options.insecure) {
    SSL_CTX_set_verify(ctx, SSL_VERIFY_NONE, nullptr);
  } else {
    SSL_CTX_set_verify(ctx, SSL_VERIFY_PEER, nullptr);
    if (!options.caFile.empty()) {
      if (SSL_CTX_load_verify_locations(ctx, options.caFile.c_str(), nullptr) != 1)
        throw ConnectionError("TLS: the CA file '" + options.caFile +
                              "' cannot be used: " + openSslErrors("not a PEM file of certificates"));
    } else if (SSL_CTX_set_default_verify_paths(ctx) != 1) {
      throw ConnectionError("TLS: the system's CA certificates cannot be read: " + openSslErrors("unknown failure"));
    }
  }
  if (options.certFile.empty() != options.keyFile.empty())
    throw ConnectionError("TLS: a client certificate needs both its certificate and its key");
  if (!options.certFile.empty()) {
    if (SSL_CTX_use_certificate_chain_file(ctx, options.certFile.c_str()) != 1)
      throw ConnectionError("TLS: the client certificate '" + options.certFile +
                            "' cannot be used: " + openSslErrors("not a PEM certificate"));
    if (SSL_CTX_use_PrivateKey_file(ctx, options.keyFile.c_str(), SSL_FILETYPE_PEM) != 1 ||
        SSL_CTX_check_private_key(ctx) != 1)
      throw ConnectionError("TLS: the client key '" + options.keyFile +
                            "' cannot be used with its certificate: " + openSslErrors("not its PEM private key"));
  }
  return context;
}

}  // namespace

struct Client::Impl {
  asio::io_context io;
  tcp::socket socket{io};
  std::unique_ptr<asio::ssl::context> tlsContext;
  std::optional<asio::ssl::stream<tcp::socket&>> tls;  ///< once the TLS handshake is done
  proto::Limits limits;
  std::string where;
  std::chrono::milliseconds timeout{0};

  /// Runs `f` on the stream messages travel on: the TLS stream, or the socket itself.
  template <typename F>
  auto withStream(F&& f) {
    if (tls) return f(*tls);
    return f(socket);
  }
  /// The TLS handshake as a client of `host` (certificate checks as TlsOptions says); throws ConnectionError naming
  /// why it failed.
  void handshake(const std::string& host, const TlsOptions& options);

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

Client::Client(const std::string& host, int port, std::chrono::milliseconds timeout, const TlsOptions& tls)
    : mImpl(std::make_unique<Impl>()) {
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
  if (tls.enabled) mImpl->handshake(host, tls);
}

void Client::Impl::handshake(const std::string& host, const TlsOptions& options) {
  tlsContext = clientContext(options);
  tls.emplace(socket, *tlsContext);
  SSL* ssl = tls->native_handle();
  boost::system::error_code parsed;
  asio::ip::make_address(host, parsed);
  const bool ipAddress = !parsed;
  // The certificate must name the host asked for: its DNS name (also sent as SNI), or its IP address.
  if (!options.insecure) {
    X509_VERIFY_PARAM* param = SSL_get0_param(ssl);
    if (ipAddress ? X509_VERIFY_PARAM_set1_ip_asc(param, host.c_str()) != 1
                  : X509_VERIFY_PARAM_set1_host(param, host.c_str(), 0) != 1)
      throw ConnectionError("TLS: '" + host + "' cannot be checked against a certificate");
  }
  if (!ipAddress) SSL_set_tlsext_host_name(ssl, host.c_str());
  const boost::system::error_code ec =
      run("TLS handshake with", [&](auto handler) {
        tls->async_handshake(asio::ssl::stream_base::client,
                             [handler](const boost::system::error_code& e) { handler(e, 0); });
      }).first;
  if (!ec) return;
  const long verify = SSL_get_verify_result(ssl);
  tls.reset();
  if (!options.insecure && verify != X509_V_OK)
    throw ConnectionError("TLS: the certificate of " + where + " is refused: " + X509_verify_cert_error_string(verify) +
                          (verify == X509_V_ERR_HOSTNAME_MISMATCH || verify == X509_V_ERR_IP_ADDRESS_MISMATCH
                               ? " (it is not made out to '" + host + "')"
                               : std::string(". Give the CA that signed it (--ca FILE), or --tls-insecure to take "
                                             "any certificate (a self-signed one, in local use only)")));
  if (ec == asio::error::eof || ec == asio::ssl::error::stream_truncated || ec == asio::error::connection_reset)
    throw ConnectionError("TLS handshake with " + where +
                          ": the server closed the connection (it may speak no TLS, refuse new connections, or want "
                          "a client certificate)");
  throw ConnectionError("TLS handshake with " + where + " failed: " + ec.message() +
                        (ec.message() == "wrong version number" || ec.message() == "packet length too long"
                             ? " (the server does not speak TLS on this port: connect without --tls)"
                             : ""));
}

bool Client::tls() const { return mImpl->tls.has_value(); }

std::string Client::tlsDescription() const {
  if (!mImpl->tls) return {};
  SSL* ssl = mImpl->tls->native_handle();
  return std::string(SSL_get_version(ssl)) + " " + SSL_get_cipher_name(ssl);
}

Client::~Client() = default;

void Client::sendBytes(const std::vector<uint8_t>& bytes) {
  const boost::system::error_code ec =
      mImpl
          ->run("sending to",
                [&](auto handler) {
                  mImpl->withStream([&](auto& stream) { asio::async_write(stream, asio::buffer(bytes), handler); });
                })
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
  const auto [ec, n] = mImpl->run("reading from", [&](auto handler) {
    mImpl->withStream([&](auto& stream) { stream.async_read_some(asio::buffer(bytes), handler); });
  });
  bytes.resize(ec ? 0 : n);
  if (ec && ec != asio::error::eof) throw ConnectionError("reading from " + mImpl->where + ": " + ec.message());
  return bytes;
}

std::pair<uint32_t, proto::Message> Client::receive() {
  std::array<uint8_t, proto::kHeaderBytes> head{};
  auto readAll = [&](asio::mutable_buffer buffer) {
    return mImpl
        ->run(
            "reading from",
            [&](auto handler) { mImpl->withStream([&](auto& stream) { asio::async_read(stream, buffer, handler); }); })
        .first;
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
  // Bytes TLS has decrypted already wait in OpenSSL, not in the socket.
  if (mImpl->tls && SSL_pending(mImpl->tls->native_handle()) > 0) return true;
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

std::string Client::authenticate(const std::string& token) {
  if (!proto::messageTypeInVersion(proto::MessageType::Authenticate, mVersion))
    throw std::invalid_argument("presenting an access token needs protocol version 5; " + mImpl->where +
                                " speaks version " + std::to_string(mVersion));
  return expect<proto::Authenticated>(call(proto::Authenticate{token}), "Authenticate").tokenId;
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
                                " encoding needs protocol version " + std::to_string(proto::firstVersionOf(encoding)) +
                                "; the server speaks version " + std::to_string(mVersion));
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

std::optional<std::chrono::milliseconds> retryAfter(proto::ErrorCode code, std::string_view message) {
  const std::optional<uint32_t> hint = proto::retryAfterMs(message);
  if (code != proto::ErrorCode::Busy && !(code == proto::ErrorCode::LimitExceeded && hint)) return std::nullopt;
  return hint ? std::chrono::milliseconds(*hint) : kBusyWithoutHint;
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
