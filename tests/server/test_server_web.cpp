// The browser transport end to end: the real `voxbrick serve --http` process, HTTP and WebSocket clients on
// loopback. The embedded files and nothing else, the protocol over a WebSocket frame for frame as over TCP, the
// Origin and token checks, WebSocket messages that are not one protocol message, slow HTTP clients, and latest wins
// on output on both transports.
#include <gtest/gtest.h>

#include <signal.h>

#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "RawSocket.h"
#include "ServerProcess.h"
#include "WebClient.h"
#include "client/Client.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using client::Client;
using nlohmann::json;
using proto::ErrorCode;
using test::Framing;
using test::HttpReply;
using test::RawSocket;
using test::ServerProcess;
using test::UpgradeRefused;
using test::WebSocketClient;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

const char* kWebScene = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [80, 64], "transfer_function": "sparse",
                         "step": 0.75})";

class WebTransportTest : public test::SparseDatasetSuite {
 protected:
  std::unique_ptr<ServerProcess> start(const std::string& extra = "") {
    return std::make_unique<ServerProcess>("--datasets " + datasets() + " --render-threads 1 --http 0 " + extra,
                                           scratch());
  }
};

std::string sourceFile(const std::string& path) {
  std::ifstream in(std::string(VOXBRICK_SOURCE_DIR) + "/" + path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST_F(WebTransportTest, HttpServesTheEmbeddedFilesAndNothingElse) {
  auto server = start();
  const int port = server->httpPort();
  const std::string index = sourceFile("web/index.html");
  ASSERT_FALSE(index.empty());

  const HttpReply root = test::httpRequest(port, "GET", "/");
  EXPECT_EQ(root.status, 200);
  EXPECT_EQ(root.body, index) << "GET / is web/index.html, byte for byte";
  EXPECT_EQ(root.header("content-type"), "text/html; charset=utf-8");
  EXPECT_EQ(root.header("cache-control"), "no-cache");
  EXPECT_EQ(root.header("x-content-type-options"), "nosniff");
  EXPECT_EQ(test::httpRequest(port, "GET", "/index.html").body, index);
  EXPECT_EQ(test::httpRequest(port, "GET", "/?token=abc&dataset=sparse").body, index) << "the query is the page's";
  const HttpReply head = test::httpRequest(port, "HEAD", "/");
  EXPECT_EQ(head.status, 200);
  EXPECT_TRUE(head.body.empty());
  EXPECT_EQ(head.header("content-length"), std::to_string(index.size()));
  // A browser that holds the file asks whether it changed.
  EXPECT_EQ(test::httpRequest(port, "GET", "/", {{"If-None-Match", root.header("etag")}}).status, 304);

  // No path reaches the file system: only the embedded files' own names match.
  for (const char* target : {"/nope.html", "/../CMakeLists.txt", "/%2e%2e/CMakeLists.txt", "/%2e%2e/", "/..",
                             "//etc/passwd", "/etc/passwd", "/web/index.html", "/./index.html", "/index.html/",
                             "http://127.0.0.1/../CMakeLists.txt", "*", "/index.html%00"}) {
    const HttpReply r = test::httpRequest(port, "GET", target);
    EXPECT_EQ(r.status, 404) << target;
    EXPECT_EQ(r.body.find("cmake_minimum_required"), std::string::npos) << target;
  }
  for (const char* method : {"POST", "PUT", "DELETE", "OPTIONS"}) {
    const HttpReply r = test::httpRequest(port, method, "/");
    EXPECT_EQ(r.status, 405) << method;
    EXPECT_EQ(r.header("allow"), "GET, HEAD");
  }
  EXPECT_EQ(test::httpRequest(port, "GET", "/ws").status, 426) << "/ws without an upgrade";
  // A request header past the limit is refused, and the server goes on.
  EXPECT_EQ(test::httpRequest(port, "GET", "/", {{"X-Padding", std::string(20000, 'a')}}).status, 431);

  // Keep-alive: two requests on one connection, both answered.
  RawSocket raw(port, Framing::None);
  const std::string two =
      "GET / HTTP/1.1\r\nHost: x\r\n\r\nGET /index.html HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  ASSERT_TRUE(raw.sendAll(std::vector<uint8_t>(two.begin(), two.end())));
  EXPECT_TRUE(raw.waitClosed(5s)) << "Connection: close is honoured";
  EXPECT_TRUE(server->running());
}

TEST_F(WebTransportTest, AWebSocketSessionGetsTheTcpFramesByteForByte) {
  auto server = start();
  WebSocketClient ws(server->httpPort());
  const proto::Capabilities capabilities = ws.hello();
  EXPECT_EQ(capabilities.version, 1);
  EXPECT_EQ(ws.listDatasets(), std::vector<std::string>{"sparse"});
  const proto::DatasetInfo info = ws.openDataset("sparse");
  EXPECT_EQ(info.name, "sparse");
  const proto::Frame overWs = ws.render(kWebScene, proto::Encoding::Png);

  Client tcp("127.0.0.1", server->port());
  tcp.hello();
  tcp.openDataset("sparse");
  const proto::Frame overTcp = tcp.render(kWebScene, proto::Encoding::Png);
  ASSERT_EQ(overWs.width, 80u);
  ASSERT_EQ(overWs.height, 64u);
  EXPECT_EQ(overWs.payload, overTcp.payload) << "the same scene gives the same PNG on both transports";
  EXPECT_GT(overWs.payload.size(), 100u);
  EXPECT_EQ(ws.openDataset("sparse"), info);
  // Errors travel the same way, and leave the session open.
  try {
    ws.openDataset("../etc");
    ADD_FAILURE() << "an unknown dataset was opened";
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.code(), ErrorCode::UnknownDataset);
  }
  EXPECT_EQ(json::parse(ws.stats())["sessions"]["active"].get<int>(), 2);
  // Stopping: the WebSocket session is told, like the TCP one, and the server exits cleanly.
  EXPECT_EQ(server->stop(SIGTERM), 0) << server->log();
  EXPECT_EQ(ws.errorsUntilClosed(), std::vector<ErrorCode>{ErrorCode::ShuttingDown});
}

// SIGTERM ends the server within a second whatever is open on its HTTP port, as a browser leaves it: a WebSocket
// session that has drawn a frame and does not read, a keep-alive connection after a page, a connection opened ahead
// with no request yet, and half a request.
TEST_F(WebTransportTest, SigtermEndsTheServerWithinASecondWhateverIsOpen) {
  auto server = start();
  WebSocketClient ws(server->httpPort());
  ws.hello();
  ws.openDataset("sparse");
  ASSERT_EQ(ws.render(kWebScene).width, 80u);
  RawSocket keepAlive(server->httpPort(), Framing::None);
  const std::string page = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: keep-alive\r\n\r\n";
  ASSERT_TRUE(keepAlive.sendAll(std::vector<uint8_t>(page.begin(), page.end())));
  RawSocket ahead(server->httpPort(), Framing::None);
  RawSocket half(server->httpPort(), Framing::None);
  const std::string start = "GET /viewer.css HTTP/1.1\r\nHost: 127.0.0.1\r\n";
  ASSERT_TRUE(half.sendAll(std::vector<uint8_t>(start.begin(), start.end())));
  std::this_thread::sleep_for(300ms);  // the page's reply written, the connections idle
  const auto sent = Clock::now();
  EXPECT_EQ(server->stop(SIGTERM, 1000ms), 0) << "not ended within a second of SIGTERM: " << server->log();
  EXPECT_LT(Clock::now() - sent, 1000ms);
}

TEST_F(WebTransportTest, OnlyAllowedOriginsWithTheTokenMayOpenTheSocket) {
  auto server = start(
      "--http-origin http://viewer.example.org:9000 --http-origin https://lab.example.org "
      "--http-token s3cret-Token_1");
  const int port = server->httpPort();
  const std::string own = "http://127.0.0.1:" + std::to_string(port);
  auto refusal = [&](const std::string& target, const std::string& origin) -> std::string {
    try {
      WebSocketClient ws(port, target, origin);
      ws.hello();
    } catch (const UpgradeRefused& e) {
      EXPECT_EQ(e.status, 403) << e.what();
      return e.body;
    }
    return "";
  };
  // Refused: no token, a wrong one, one of another length, a page of another site.
  EXPECT_NE(refusal("/ws", own).find("access token is required"), std::string::npos);
  EXPECT_NE(refusal("/ws?token=s3cret-Token_2", own).find("wrong access token"), std::string::npos);
  EXPECT_NE(refusal("/ws?token=s3cret", own).find("wrong access token"), std::string::npos);
  EXPECT_NE(refusal("/ws?token=s3cret-Token_1", "http://evil.example.com").find("Origin"), std::string::npos);
  EXPECT_NE(refusal("/ws?token=s3cret-Token_1", "http://viewer.example.org:9001").find("not allowed"),
            std::string::npos);
  EXPECT_NE(refusal("/ws?token=s3cret-Token_1", "null").find("not allowed"), std::string::npos);
  EXPECT_NE(refusal("/other?token=s3cret-Token_1", "").find("/ws"), std::string::npos);
  // Accepted: the page's own origin, a configured one, and a client that sends no Origin (not a browser).
  EXPECT_EQ(refusal("/ws?token=s3cret-Token_1", own), "");
  EXPECT_EQ(refusal("/ws?dataset=x&token=s3cret-Token_1", own), "") << "the token among other parameters";
  // Same origin means the Origin's host and port equal the Host header's: another name of this machine is another
  // origin.
  EXPECT_NE(refusal("/ws?token=s3cret-Token_1", "http://localhost:" + std::to_string(port)), "");
  EXPECT_EQ(refusal("/ws?token=s3cret-Token_1", "http://viewer.example.org:9000"), "");
  EXPECT_EQ(refusal("/ws?token=s3cret-Token_1", "https://LAB.example.org"), "");
  EXPECT_EQ(refusal("/ws?token=s3cret-Token_1", ""), "");
  // The page itself needs no token (it carries it on to /ws). The log names the URL to open, never the token.
  EXPECT_EQ(test::httpRequest(port, "GET", "/").status, 200);
  EXPECT_NE(server->log().find("viewer at http://127.0.0.1:" + std::to_string(port) + "/ (add ?token="),
            std::string::npos)
      << server->log();
  EXPECT_EQ(server->log().find("s3cret-Token_1"), std::string::npos) << server->log();

  // Without a configured list, only the page's own origin.
  auto plain = start();
  const int plainPort = plain->httpPort();
  EXPECT_THROW(WebSocketClient(plainPort, "/ws", "http://127.0.0.1:1"), UpgradeRefused);
  EXPECT_NO_THROW(WebSocketClient(plainPort, "/ws", "http://127.0.0.1:" + std::to_string(plainPort)).hello());
}

// One WebSocket message carries exactly one protocol message: what is not one is answered as on TCP.
TEST_F(WebTransportTest, WebSocketMessagesThatAreNotOneProtocolMessageAreAnswered) {
  auto server = start("--max-message-bytes 65536");
  const int port = server->httpPort();
  WebSocketClient good(port);
  good.hello();
  good.openDataset("sparse");
  auto closedWith = [&](const std::vector<uint8_t>& wire) {
    RawSocket s(port, Framing::WebSocket);
    EXPECT_TRUE(s.sendAll(wire));
    std::vector<ErrorCode> codes;
    EXPECT_TRUE(s.waitClosed(10s, &codes));
    return codes;
  };
  const std::vector<uint8_t> hello = proto::encode(proto::Hello{1, 1, "x"}, 1);
  const std::string text = "{\"hello\": 1}";
  // A text message; a message shorter than a header; one longer than its header announces.
  EXPECT_EQ(closedWith(RawSocket::webSocketFrame(std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size()),
                                                 1, true)),
            std::vector<ErrorCode>{ErrorCode::Malformed});
  EXPECT_EQ(closedWith(RawSocket::webSocketFrame(std::span(hello).first(10), 2, true)),
            std::vector<ErrorCode>{ErrorCode::Malformed});
  std::vector<uint8_t> longer = hello;
  longer.insert(longer.end(), 100, 0);
  EXPECT_EQ(closedWith(RawSocket::webSocketFrame(longer, 2, true)), std::vector<ErrorCode>{ErrorCode::Malformed});
  // (Garbage and oversized headers are answered as on TCP: test_server_hostile.cpp runs them on both transports.)
  {  // a body shorter than its header announces: that request is answered Malformed, the session goes on
    RawSocket s(port, Framing::WebSocket);
    ASSERT_TRUE(s.sendMessage(hello));
    ASSERT_TRUE(s.receive(10s));
    std::vector<uint8_t> open = proto::encode(proto::OpenDataset{"sparse"}, 2);
    open.pop_back();
    ASSERT_TRUE(s.sendAll(RawSocket::webSocketFrame(open, 2, true)));
    const auto reply = s.receiveWithId(10s);
    ASSERT_TRUE(reply);
    EXPECT_EQ(reply->first, 2u);
    ASSERT_TRUE(std::holds_alternative<proto::Error>(reply->second));
    EXPECT_EQ(std::get<proto::Error>(reply->second).code, ErrorCode::Malformed);
    // A protocol message split over fragments is one message.
    const std::vector<uint8_t> list = proto::encode(proto::ListDatasets{}, 3);
    std::vector<uint8_t> fragments = RawSocket::webSocketFrame(std::span(list).first(5), 2, false);
    const auto second = RawSocket::webSocketFrame(std::span(list).subspan(5), 0, true);
    fragments.insert(fragments.end(), second.begin(), second.end());
    ASSERT_TRUE(s.sendAll(fragments));
    const auto names = s.receiveWithId(10s);
    ASSERT_TRUE(names);
    EXPECT_EQ(names->first, 3u);
    EXPECT_TRUE(std::holds_alternative<proto::DatasetList>(names->second));
  }
  EXPECT_EQ(good.render(kWebScene).width, 80u) << "the other sessions go on";
}

// An HTTP client that never upgrades is pending like a TCP connection before its Hello: a silent one, or one that
// trickles its request (slowloris), is closed within the Hello timeout, and good clients get in meanwhile.
TEST_F(WebTransportTest, SlowHttpClientsHoldNothingForLong) {
  auto server = start("--hello-timeout 1 --max-pending-connections 4");
  const int port = server->httpPort();
  std::vector<std::unique_ptr<RawSocket>> silent, trickling;
  for (int i = 0; i < 3; ++i) silent.push_back(std::make_unique<RawSocket>(port, Framing::None));
  for (int i = 0; i < 3; ++i) trickling.push_back(std::make_unique<RawSocket>(port, Framing::None));
  const std::string request = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: 1\r\n\r\n";
  const auto t0 = Clock::now();
  bool allClosed = false;
  for (size_t i = 0; i < request.size() && !allClosed; ++i) {
    allClosed = true;
    for (auto& s : trickling) {
      s->sendSome(std::span(reinterpret_cast<const uint8_t*>(request.data()) + i, 1));
      allClosed = s->waitClosed(100ms) && allClosed;
    }
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
  EXPECT_TRUE(allClosed) << "a trickled request outlived the Hello timeout";
  EXPECT_LT(elapsed, 3.0);
  for (auto& s : silent) EXPECT_TRUE(s->waitClosed(2s)) << "a silent HTTP connection outlived the Hello timeout";
  // Pending connections are counted and evicted as on TCP: a good WebSocket client gets in past a full pool.
  for (int i = 0; i < 6; ++i) silent.push_back(std::make_unique<RawSocket>(port, Framing::None));
  WebSocketClient ws(port);
  EXPECT_EQ(ws.hello().version, 1);
  Client tcp("127.0.0.1", server->port());
  tcp.hello();
  EXPECT_EQ(tcp.listDatasets().size(), 1u);
  EXPECT_GE(json::parse(tcp.stats())["sessions"]["evicted"].get<int>(), 1);
}

TEST_F(WebTransportTest, HttpSettingProblemsAreNamed) {
  auto server = start();
  auto r =
      test::runVoxbrick("serve --datasets " + datasets() + " --port 0 --http " + std::to_string(server->httpPort()));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("cannot listen on 127.0.0.1:" + std::to_string(server->httpPort()) + " (HTTP)"),
            std::string::npos)
      << r.output;
  r = test::runVoxbrick("serve --datasets " + datasets() + " --port 0 --http 0 --http-token 'a b'");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("http.token"), std::string::npos) << r.output;
  r = test::runVoxbrick("serve --datasets " + datasets() + " --port 0 --http 0 --http-origin example.org");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("'example.org' is not an origin"), std::string::npos) << r.output;
  r = test::runVoxbrick("serve --datasets " + datasets() + " --port 0 --http-port-file x");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("--http-port-file needs --http"), std::string::npos) << r.output;
}

class LatestWinsTest : public test::SparseDatasetSuite, public ::testing::WithParamInterface<Framing> {};

// A client that reads slower than frames are made gets the newest frame, never a queue of old ones: at most one
// frame waits unsent, and the requests of the frames it replaced are answered Superseded.
TEST_P(LatestWinsTest, ASlowReaderGetsTheNewestFrameNotAQueue) {
  // Frames of 16 MiB, more than loopback's socket buffers hold, so they wait in the server; reading is never
  // paused (so every request is read while frames wait).
  test::writeFile(scratch() / "latest.toml",
                  std::string("[limits]\npause_reading_bytes = 268435456\nmax_message_bytes = 33554432\n"));
  ServerProcess server(
      "--config " + (scratch() / "latest.toml").string() + " --datasets " + datasets() + " --render-threads 1 --http 0",
      scratch());
  RawSocket s(GetParam() == Framing::Tcp ? server.port() : server.httpPort(), GetParam());
  ASSERT_TRUE(s.sendMessage(proto::encode(proto::Hello{1, 1, "slow"}, 1)));
  ASSERT_TRUE(s.sendMessage(proto::encode(proto::OpenDataset{"sparse"}, 2)));
  std::map<uint32_t, std::string> replies;
  for (int i = 0; i < 2; ++i) {
    const auto reply = s.receiveWithId(30s);
    ASSERT_TRUE(reply);
    replies[reply->first] = "ok";
  }
  constexpr uint32_t kRenders = 6;
  for (uint32_t i = 0; i < kRenders; ++i) {
    json scene = json::parse(R"({"size": [2048, 2048], "transfer_function": "sparse", "step": 4})");
    scene["camera"]["orbit"] = {40.0 + 10 * i, 25, 20};
    ASSERT_TRUE(s.sendMessage(proto::encode(proto::RenderRequest{proto::Encoding::RawRgba8, scene.dump()}, 10 + i)));
    std::this_thread::sleep_for(700ms);  // each is drawn before the next arrives: none is replaced while waiting
  }
  int frames = 0, superseded = 0;
  uint32_t lastFrame = 0;
  while (replies.size() < 2 + kRenders) {
    const auto reply = s.receiveWithId(30s);
    ASSERT_TRUE(reply) << "a request was not answered";
    ASSERT_FALSE(replies.count(reply->first)) << "two replies to request " << reply->first;
    if (const auto* e = std::get_if<proto::Error>(&reply->second)) {
      EXPECT_EQ(e->code, ErrorCode::Superseded) << e->message;
      ++superseded;
      replies[reply->first] = "superseded";
    } else {
      ASSERT_TRUE(std::holds_alternative<proto::Frame>(reply->second));
      ++frames;
      lastFrame = std::max(lastFrame, reply->first);
      replies[reply->first] = "frame";
    }
  }
  EXPECT_EQ(replies[10 + kRenders - 1], "frame") << "the newest frame is the one kept";
  EXPECT_GE(superseded, 2) << frames << " frames went out to a client that was not reading";
  Client c("127.0.0.1", server.port());
  c.hello();
  const json stats = json::parse(c.stats());
  EXPECT_LT(stats["output"]["peak_queued_bytes"].get<double>(), 3.5 * (16 << 20))
      << "more than one frame being written and one waiting were held";
}

INSTANTIATE_TEST_SUITE_P(Transports, LatestWinsTest, ::testing::Values(Framing::Tcp, Framing::WebSocket),
                         test::framingName<::testing::TestParamInfo<Framing>>);

}  // namespace
}  // namespace voxbrick
