// TLS on both transports, with the real `voxbrick serve` process and certificates made at test time with Debian's
// openssl: the protocol end to end over TLS, clients that refuse a certificate they cannot trust, the protocol
// versions and ciphers the server takes (checked with `openssl s_client`), clients of the wrong kind told why, https://
// and wss://, the certificate read again on SIGHUP while a session stays, client certificates, startup errors; and the
// handshakes of hostile clients counted against the pending connections like any connection without Hello.
#include <gtest/gtest.h>

#include <poll.h>
#include <signal.h>

#include <atomic>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <nlohmann/json.hpp>

#include "RawSocket.h"
#include "ServerProcess.h"
#include "TestCerts.h"
#include "WebClient.h"
#include "client/Client.h"
#include "image/FrameImage.h"
#include "support/TestSupport.h"

namespace voxbrick::tls_tests {
namespace {

using client::Client;
using client::ConnectionError;
using client::ServerError;
using client::TlsOptions;
using nlohmann::json;
using test::ServerProcess;
using test::TestCerts;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

#define EXPECT_HAS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

const char* kScene = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [80, 64], "transfer_function": "sparse"})";

std::string q(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

class TlsServerTest : public test::SparseDatasetSuite {
 protected:
  static void SetUpTestSuite() {
    SparseDatasetSuite::SetUpTestSuite();
    sCerts = new TestCerts(TestCerts::make(scratch() / "certs"));
  }
  static void TearDownTestSuite() {
    delete sCerts;
    sCerts = nullptr;
    SparseDatasetSuite::TearDownTestSuite();
  }
  static const TestCerts& certs() { return *sCerts; }
  /// A server speaking TLS with `cert` and `key` on both ports, with `extra` options.
  static std::unique_ptr<ServerProcess> serveTls(const std::string& extra = "", const std::filesystem::path& cert = {},
                                                 const std::filesystem::path& key = {}) {
    return serve("--render-threads 1 --http 0 --tls-cert " + q(cert.empty() ? certs().serverCert : cert) +
                 " --tls-key " + q(key.empty() ? certs().serverKey : key) + " " + extra);
  }
  /// TLS options trusting the test CA.
  static TlsOptions trusting(const std::filesystem::path& ca) {
    TlsOptions tls;
    tls.enabled = true;
    tls.caFile = ca.string();
    return tls;
  }
  /// What `openssl s_client` makes of a connection to 127.0.0.1:`port` with `options`, the test CA trusted.
  static test::CommandResult sClient(int port, const std::string& options) {
    return test::runShell("echo | timeout 20 openssl s_client -connect 127.0.0.1:" + std::to_string(port) +
                          " -CAfile " + q(certs().caCert) + " " + options + " 2>&1");
  }

  static inline TestCerts* sCerts = nullptr;
};

/// Whether `frame` and `other` are the same image within 1/255 per channel.
void expectSameImage(const proto::Frame& frame, const proto::Frame& other) {
  const image::Image8 a = image::decodeFrameImage(frame), b = image::decodeFrameImage(other);
  ASSERT_EQ(a.width, b.width);
  ASSERT_EQ(a.height, b.height);
  int worst = 0;
  size_t lit = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) worst = std::max(worst, std::abs(int(a.rgba[i]) - int(b.rgba[i])));
  for (size_t i = 0; i < a.rgba.size(); i += 4) lit += a.rgba[i] + a.rgba[i + 1] + a.rgba[i + 2] > 0;
  EXPECT_LE(worst, 1);
  EXPECT_GT(lit, 100u) << "the frame shows the volume";
}

TEST_F(TlsServerTest, TheProtocolTravelsOverTlsAndItsFramesAreThoseInTheClear) {
  auto tls = serveTls();
  auto plain = serve("--render-threads 1");
  Client secure("127.0.0.1", tls->port(), 30s, trusting(certs().caCert));
  EXPECT_TRUE(secure.tls());
  EXPECT_HAS(secure.tlsDescription(), "TLSv1.3");
  const proto::Capabilities caps = secure.hello("tls-test");
  EXPECT_EQ(caps.version, proto::kMaxVersion);
  EXPECT_EQ(secure.listDatasets(), std::vector<std::string>{"sparse"});
  secure.openDataset("sparse");
  Client clear("127.0.0.1", plain->port(), 30s);
  clear.hello("plain-test");
  clear.openDataset("sparse");
  EXPECT_FALSE(clear.tls());
  expectSameImage(secure.render(kScene), clear.render(kScene));
  // Large frames too (a raw 512² frame is a megabyte: many TLS records).
  const std::string big = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [512, 512], "transfer_function": "sparse"})";
  expectSameImage(secure.render(big, proto::Encoding::ZstdRgba8), clear.render(big, proto::Encoding::ZstdRgba8));
  EXPECT_EQ(plain->log().find("without TLS"), std::string::npos) << "on loopback, no warning";
  // The command line, with the CA given.
  const auto r =
      test::runVoxbrick("request 127.0.0.1:" + std::to_string(tls->port()) + " --tls --ca " + q(certs().caCert) +
                        " --dataset sparse --size 64x48 -o " + q(scratch() / "tls-frame.png"));
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_TRUE(std::filesystem::exists(scratch() / "tls-frame.png"));
  secure.goodbye();
  EXPECT_EQ(tls->stop(SIGTERM), 0) << tls->log();
}

TEST_F(TlsServerTest, AClientRefusesACertificateItCannotTrust) {
  auto server = serveTls();
  const auto refusal = [&](const TlsOptions& tls, int port) -> std::string {
    try {
      Client c("127.0.0.1", port, 20s, tls);
      c.hello();
    } catch (const ConnectionError& e) {
      return e.what();
    }
    return "";
  };
  // Signed by a CA the client was not given (and not one of the system's).
  const std::string wrongCa = refusal(trusting(certs().wrongCaCert), server->port());
  EXPECT_HAS(wrongCa, "certificate of 127.0.0.1:" + std::to_string(server->port()) + " is refused");
  EXPECT_HAS(wrongCa, "--ca");
  TlsOptions system;
  system.enabled = true;
  EXPECT_HAS(refusal(system, server->port()), "is refused");
  // Taken when asked to take any (a self-signed certificate in local use), and with the right CA.
  TlsOptions insecure = system;
  insecure.insecure = true;
  EXPECT_EQ(refusal(insecure, server->port()), "");
  EXPECT_EQ(refusal(trusting(certs().caCert), server->port()), "");
  // A server whose certificate another CA signed, and one whose certificate names another host.
  auto impostor = serveTls("", certs().wrongCert, certs().wrongKey);
  EXPECT_HAS(refusal(trusting(certs().caCert), impostor->port()), "is refused");
  auto elsewhere = serveTls("", certs().elsewhereCert, certs().elsewhereKey);
  EXPECT_HAS(refusal(trusting(certs().caCert), elsewhere->port()), "it is not made out to '127.0.0.1'");
  // The command says so and fails.
  const auto r = test::runVoxbrick("request 127.0.0.1:" + std::to_string(impostor->port()) + " --tls --ca " +
                                   q(certs().caCert) + " --list");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_HAS(r.output, "is refused: unable to get local issuer certificate");
  // The servers saw the handshakes fail, and counted them.
  EXPECT_HAS(server->log(), "TLS handshake failed");
}

TEST_F(TlsServerTest, OnlyTls12AndLaterWithForwardSecrecyAndAeadCiphersAreTaken) {
  auto server = serveTls();
  // The client at security level 0 offers TLS 1.1 at all; the server refuses it.
  const auto old = sClient(server->port(), "-tls1_1 -cipher DEFAULT@SECLEVEL=0");
  EXPECT_HAS(old.output, "alert protocol version");
  const auto v12 = sClient(server->port(), "-tls1_2");
  EXPECT_HAS(v12.output, "Protocol  : TLSv1.2");
  EXPECT_HAS(v12.output, "Cipher is ECDHE-ECDSA-AES128-GCM-SHA256");
  EXPECT_HAS(v12.output, "Verify return code: 0 (ok)");
  const auto v13 = sClient(server->port(), "-tls1_3");
  EXPECT_HAS(v13.output, "New, TLSv1.3, Cipher is TLS_");
  // No RSA key exchange (no forward secrecy), no CBC (not AEAD), whatever the client insists on.
  for (const char* weak : {"AES128-SHA", "AES256-GCM-SHA384", "ECDHE-ECDSA-AES128-SHA", "ECDHE-ECDSA-AES256-SHA384"}) {
    const auto r = sClient(server->port(), std::string("-tls1_2 -cipher ") + weak);
    EXPECT_HAS(r.output, "handshake failure");
    EXPECT_HAS(r.output, "Cipher is (NONE)");
  }
  // The HTTP port holds to the same.
  EXPECT_HAS(sClient(server->httpPort(), "-tls1_1 -cipher DEFAULT@SECLEVEL=0").output, "alert protocol version");
  EXPECT_HAS(sClient(server->httpPort(), "-tls1_2 -cipher AES128-SHA").output, "handshake failure");
  EXPECT_HAS(sClient(server->httpPort(), "-tls1_3").output, "New, TLSv1.3");
  const std::string log = server->log();
  EXPECT_HAS(log, "TLS handshake failed: unsupported protocol");
  EXPECT_HAS(log, "TLS handshake failed: no shared cipher");
  Client c("127.0.0.1", server->port(), 20s, trusting(certs().caCert));
  c.hello();
  EXPECT_EQ(json::parse(c.stats())["refusals"]["tls"].get<int>(), 7) << "every refused handshake is counted";
}

TEST_F(TlsServerTest, ClientsOfTheWrongKindAreToldWhy) {
  auto tls = serveTls();
  // A client in the clear on the TLS port: a protocol Error in the clear says so.
  try {
    Client c("127.0.0.1", tls->port(), 20s);
    c.hello();
    ADD_FAILURE() << "a client in the clear was served on the TLS port";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), proto::ErrorCode::UnexpectedMessage);
    EXPECT_HAS(e.what(), "this server speaks TLS");
  }
  // A browser sent to http:// on the https port.
  const test::HttpReply reply = test::httpRequest(tls->httpPort(), "GET", "/");
  EXPECT_EQ(reply.status, 400);
  EXPECT_HAS(reply.body, "open it with https://");
  // A TLS client of a server in the clear.
  auto plain = serve("--render-threads 1");
  try {
    Client c("127.0.0.1", plain->port(), 20s, trusting(certs().caCert));
    ADD_FAILURE() << "a TLS handshake succeeded with a server in the clear";
  } catch (const ConnectionError& e) {
    EXPECT_HAS(e.what(), "TLS handshake with 127.0.0.1:" + std::to_string(plain->port()));
  }
  EXPECT_TRUE(tls->running());
}

TEST_F(TlsServerTest, HttpsServesTheViewerAndWssTheProtocol) {
  auto server = serveTls("--http-token s3cret");
  const std::string ca = certs().caCert.string();
  const test::HttpReply page = test::httpsRequest(server->httpPort(), ca, "GET", "/");
  EXPECT_EQ(page.status, 200);
  EXPECT_HAS(page.body, "<!doctype html>");
  EXPECT_EQ(test::httpsRequest(server->httpPort(), ca, "GET", "/presets.json").status, 403);
  EXPECT_EQ(test::httpsRequest(server->httpPort(), ca, "GET", "/presets.json?token=s3cret").status, 200);
  // The protocol over wss://, the viewer's origin being https://.
  test::WebSocketClient ws(server->httpPort(), "/ws?token=s3cret",
                           "https://127.0.0.1:" + std::to_string(server->httpPort()), 30s, ca);
  ws.hello();
  EXPECT_EQ(ws.listDatasets(), std::vector<std::string>{"sparse"});
  ws.openDataset("sparse");
  Client c("127.0.0.1", server->port(), 30s, trusting(certs().caCert));
  c.hello();
  c.openDataset("sparse");
  expectSameImage(ws.render(kScene), c.render(kScene));
  EXPECT_THROW(test::WebSocketClient(server->httpPort(), "/ws?token=wrong", "", 10s, ca), test::UpgradeRefused);
  const json stats = json::parse(c.stats());
  EXPECT_EQ(stats["refusals"]["tls"].get<int>(), 0);
  // The address serve prints is https://, and carries no token.
  EXPECT_HAS(server->log(), "viewer at https://127.0.0.1:" + std::to_string(server->httpPort()) + "/");
  EXPECT_EQ(server->log().find("s3cret"), std::string::npos) << server->log();
}

TEST_F(TlsServerTest, SighupReadsTheCertificateAgainWhileSessionsStayAndOneDrags) {
  const auto cert = scratch() / "reload-cert.pem", key = scratch() / "reload-key.pem";
  std::filesystem::copy_file(certs().serverCert, cert, std::filesystem::copy_options::overwrite_existing);
  std::filesystem::copy_file(certs().serverKey, key, std::filesystem::copy_options::overwrite_existing);
  auto server = serveTls("", cert, key);
  Client stays("127.0.0.1", server->port(), 30s, trusting(certs().caCert));
  stays.hello();
  stays.openDataset("sparse");
  const proto::Frame before = stays.render(kScene);
  EXPECT_HAS(sClient(server->port(), "").output, "subject=CN = voxbrick test server\n");
  // A client drags all along (a new camera for every frame, each waited for): none of its frames fails.
  std::atomic<bool> stopDragging{false}, dragFailed{false};
  std::atomic<int> dragFrames{0};
  std::string dragFailure;  // written by the drag's thread before dragFailed, read after it
  std::thread dragging([&] {
    try {
      Client drag("127.0.0.1", server->port(), 30s, trusting(certs().caCert));
      drag.hello();
      drag.openDataset("sparse");
      for (int i = 0; !stopDragging; ++i) {
        const std::string scene = R"({"camera": {"orbit": [)" + std::to_string(40 + i % 90) +
                                  R"(, 25, 2.2]}, "size": [80, 64], "transfer_function": "sparse"})";
        if (drag.render(scene).width != 80) throw std::runtime_error("a frame of the wrong size");
        ++dragFrames;
      }
    } catch (const std::exception& e) {
      dragFailure = e.what();
      dragFailed = true;
    }
  });
  struct Joined {  // however the test ends
    std::atomic<bool>& stop;
    std::thread& thread;
    ~Joined() {
      stop = true;
      if (thread.joinable()) thread.join();
    }
  } joined{stopDragging, dragging};
  const auto dragged = [&](int atLeast) {
    const auto deadline = Clock::now() + 20s;
    while (dragFrames < atLeast && !dragFailed && Clock::now() < deadline) std::this_thread::sleep_for(20ms);
    return dragFrames.load();
  };
  EXPECT_GE(dragged(3), 3) << "the drag did not start";

  // Reissued: the new certificate for new handshakes, the open session untouched.
  std::filesystem::copy_file(certs().otherCert, cert, std::filesystem::copy_options::overwrite_existing);
  std::filesystem::copy_file(certs().otherKey, key, std::filesystem::copy_options::overwrite_existing);
  ::kill(server->pid(), SIGHUP);
  const auto waitForLog = [&](const std::string& text) {
    const auto deadline = Clock::now() + 10s;
    while (server->log().find(text) == std::string::npos && Clock::now() < deadline) std::this_thread::sleep_for(20ms);
    return server->log().find(text) != std::string::npos;
  };
  ASSERT_TRUE(waitForLog("SIGHUP: TLS certificate and key read again")) << server->log();
  const int draggedAtReload = dragFrames;
  EXPECT_GE(dragged(draggedAtReload + 3), draggedAtReload + 3) << "the drag goes on after the reload";
  EXPECT_HAS(sClient(server->port(), "").output, "subject=CN = \"voxbrick test server, reissued\"");
  EXPECT_HAS(sClient(server->httpPort(), "").output, "subject=CN = \"voxbrick test server, reissued\"");
  expectSameImage(stays.render(kScene), before);

  // A key that does not belong to the certificate: refused, and the reissued pair stays in use.
  std::filesystem::copy_file(certs().wrongKey, key, std::filesystem::copy_options::overwrite_existing);
  ::kill(server->pid(), SIGHUP);
  ASSERT_TRUE(waitForLog("the current ones stay in use")) << server->log();
  EXPECT_HAS(server->log(), "does not belong to the certificate");
  Client fresh("127.0.0.1", server->port(), 30s, trusting(certs().caCert));
  fresh.hello();
  EXPECT_EQ(fresh.listDatasets(), std::vector<std::string>{"sparse"});
  expectSameImage(stays.render(kScene), before);
  stopDragging = true;
  dragging.join();
  EXPECT_FALSE(dragFailed) << "a frame of the drag failed across the reloads: " << dragFailure;
  EXPECT_TRUE(server->running()) << "SIGHUP reloads, it does not stop the server";
}

TEST_F(TlsServerTest, AServerWithACaOfClientsTakesOnlyClientsWithItsCertificates) {
  auto server = serveTls("--tls-ca " + q(certs().caCert));
  TlsOptions without = trusting(certs().caCert);
  EXPECT_THROW(
      {
        Client c("127.0.0.1", server->port(), 20s, without);
        c.hello();
      },
      ConnectionError);
  TlsOptions with = without;
  with.certFile = certs().clientCert.string();
  with.keyFile = certs().clientKey.string();
  Client c("127.0.0.1", server->port(), 20s, with);
  EXPECT_EQ(c.hello().version, proto::kMaxVersion);
  // A client certificate of another CA is refused too.
  TlsOptions stranger = without;
  stranger.certFile = certs().wrongCert.string();
  stranger.keyFile = certs().wrongKey.string();
  EXPECT_THROW(
      {
        Client s("127.0.0.1", server->port(), 20s, stranger);
        s.hello();
      },
      ConnectionError);
  EXPECT_HAS(server->log(), "clients must present a certificate signed by a CA of");
}

TEST_F(TlsServerTest, BadTlsFilesAreRefusedAtStartNamingTheFile) {
  const auto serveWith = [&](const std::string& tls) {
    return test::runVoxbrick("serve --no-config --port 0 --render-threads 1 --datasets " + datasets() + " " + tls);
  };
  auto r = serveWith("--tls-cert " + q(scratch() / "missing.pem") + " --tls-key " + q(certs().serverKey));
  EXPECT_NE(r.exitCode, 0);
  EXPECT_HAS(r.output, "tls.cert '" + (scratch() / "missing.pem").string() + "' cannot be read");
  r = serveWith("--tls-cert " + q(certs().serverCert) + " --tls-key " + q(certs().wrongKey));
  EXPECT_NE(r.exitCode, 0);
  EXPECT_HAS(r.output, "does not belong to the certificate");
  r = serveWith("--tls-cert " + q(certs().serverKey) + " --tls-key " + q(certs().serverKey));
  EXPECT_NE(r.exitCode, 0);
  EXPECT_HAS(r.output, "holds no PEM certificate");
  r = serveWith("--tls-cert " + q(certs().serverCert));
  EXPECT_NE(r.exitCode, 0);
  EXPECT_HAS(r.output, "tls.cert is set without tls.key");
  // The client's options need --tls.
  r = test::runVoxbrick("request 127.0.0.1:1 --ca " + q(certs().caCert) + " --list");
  EXPECT_NE(r.exitCode, 0);
  EXPECT_HAS(r.output, "--tls");
}

TEST_F(TlsServerTest, ListeningOffLoopbackWithoutTlsIsWarnedOf) {
  auto open = serve("--render-threads 1 --host 0.0.0.0");
  EXPECT_HAS(open->log(), "the TCP port listens on 0.0.0.0 without TLS");
  auto secure = serveTls("--host 0.0.0.0");
  EXPECT_EQ(secure->log().find("without TLS"), std::string::npos) << secure->log();
}

/// A connection that completes its TLS handshake and then says nothing; whether the server closed it.
class IdleTlsConnection {
 public:
  IdleTlsConnection(int port, boost::asio::ssl::context& context) : mStream(mIo, context) {
    mStream.next_layer().connect({boost::asio::ip::make_address("127.0.0.1"), uint16_t(port)});
    boost::system::error_code ec;
    mStream.handshake(boost::asio::ssl::stream_base::client, ec);
    mHandshaken = !ec;
  }
  bool handshaken() const { return mHandshaken; }
  /// Reads until the server closes the connection or `timeout` passes; whether it closed.
  bool waitClosed(std::chrono::milliseconds timeout) {
    if (!mHandshaken) return true;
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
      if (left.count() <= 0) return false;
      // Polled: a blocking read of Asio's waits past any socket timeout.
      pollfd p{mStream.next_layer().native_handle(), POLLIN, 0};
      if (::poll(&p, 1, int(left.count())) <= 0) continue;
      char byte;
      boost::system::error_code ec;
      mStream.read_some(boost::asio::buffer(&byte, 1), ec);
      if (ec) return true;
    }
  }

 private:
  boost::asio::io_context mIo;
  boost::asio::ssl::stream<boost::asio::ip::tcp::socket> mStream;
  bool mHandshaken = false;
};

/// The first bytes of a TLS 1.2 ClientHello record, cut short: a handshake that never completes.
std::vector<uint8_t> truncatedClientHello() {
  return {0x16, 0x03, 0x01, 0x02, 0x00, 0x01, 0x00, 0x01, 0xfc, 0x03, 0x03, 0x5a, 0x5b, 0x5c};
}

// A TLS connection is pending from its accept until its Hello, handshake included: silent sockets, handshakes that
// stop half way and handshakes completed without a Hello all count against max_pending_connections and the Hello
// deadline, and cannot keep a good client out, on either port.
TEST_F(TlsServerTest, HandshakesWithoutHelloCountAsPendingConnectionsOnBothPorts) {
  auto server = serveTls("--hello-timeout 2 --max-pending-connections 8");
  boost::asio::ssl::context context(boost::asio::ssl::context::tls_client);
  context.set_verify_mode(boost::asio::ssl::verify_none);
  for (const bool web : {false, true}) {
    SCOPED_TRACE(web ? "HTTP port (wss)" : "TCP port");
    const int port = web ? server->httpPort() : server->port();
    std::vector<std::unique_ptr<test::RawSocket>> silent, truncated;
    std::vector<std::unique_ptr<IdleTlsConnection>> idle;
    for (int i = 0; i < 12; ++i) {
      silent.push_back(std::make_unique<test::RawSocket>(port, test::Framing::None));
      truncated.push_back(std::make_unique<test::RawSocket>(port, test::Framing::None));
      truncated.back()->sendAll(truncatedClientHello());
    }
    // A flood of completed handshakes that never say Hello, from four threads at once.
    std::mutex idleMutex;
    std::vector<std::thread> flood;
    for (int t = 0; t < 4; ++t)
      flood.emplace_back([&] {
        for (int i = 0; i < 8; ++i) {
          auto c = std::make_unique<IdleTlsConnection>(port, context);
          std::lock_guard lock(idleMutex);
          idle.push_back(std::move(c));
        }
      });
    for (std::thread& t : flood) t.join();
    const auto t0 = Clock::now();
    if (web) {
      test::WebSocketClient good(port, "/ws", "", 10s, certs().caCert.string());
      good.hello();
      good.openDataset("sparse");
      EXPECT_NO_THROW(good.render(kScene));
    } else {
      Client good("127.0.0.1", port, 10s, trusting(certs().caCert));
      good.hello();
      good.openDataset("sparse");
      EXPECT_NO_THROW(good.render(kScene));
    }
    EXPECT_LT(secondsSince(t0), 3.0) << "a good client is served at once";
    // Every one of them is closed by the Hello deadline (2 s) at the latest, or evicted before.
    for (auto& s : silent) EXPECT_TRUE(s->waitClosed(4s)) << "a silent connection outlived the Hello deadline";
    for (auto& s : truncated) EXPECT_TRUE(s->waitClosed(4s)) << "a half handshake outlived the Hello deadline";
    for (auto& c : idle) EXPECT_TRUE(c->waitClosed(4s)) << "a handshake without Hello outlived the Hello deadline";
  }
  Client c("127.0.0.1", server->port(), 10s, trusting(certs().caCert));
  c.hello();
  const json stats = json::parse(c.stats());
  EXPECT_EQ(stats["sessions"]["pending"].get<int>(), 0);
  EXPECT_GT(stats["sessions"]["evicted"].get<int>(), 0) << "the pool of 8 was full: older connections gave way";
  EXPECT_GE(stats["sessions"]["timed_out"].get<int>(), 1);
  EXPECT_TRUE(server->running());
}

}  // namespace
}  // namespace voxbrick::tls_tests

#undef EXPECT_HAS
