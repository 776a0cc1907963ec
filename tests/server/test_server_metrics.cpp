// /metrics of the real `voxbrick serve --http` process: behind the access token (query or Bearer header), in
// Prometheus' text format, its figures following what clients on both transports do, and every family it exposes
// listed in docs/server.md.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "PrometheusText.h"
#include "RawSocket.h"
#include "ServerProcess.h"
#include "WebClient.h"
#include "client/Client.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::ParsedMetrics;
using test::ServerProcess;
using namespace std::chrono_literals;

constexpr const char* kMetricsToken = "metrics-Token_1";

/// A small scene of the sparse dataset, with `extra` keys ("" or `"key": value, ...`).
std::string metricsScene(const std::string& extra = "") {
  return R"({)" + extra + (extra.empty() ? "" : ", ") +
         R"("camera": {"orbit": [40, 25, 2.2]}, "size": [64, 48], "transfer_function": "sparse", "step": 0.75})";
}

class MetricsEndpointTest : public test::SparseDatasetSuite {
 protected:
  void SetUp() override { start(); }
  /// (Re)starts the server, with `extra` options.
  void start(const std::string& extra = "") {
    server.reset();
    server = std::make_unique<ServerProcess>(
        "--datasets " + datasets() + " --render-threads 1 --http 0 --http-token " + kMetricsToken + " " + extra,
        scratch());
  }

  /// GET /metrics with the token as a Bearer header, parsed; fails the test unless it is a 200 of the text format.
  ParsedMetrics scrape() {
    const test::HttpReply r = test::httpRequest(server->httpPort(), "GET", "/metrics",
                                                {{"Authorization", std::string("Bearer ") + kMetricsToken}});
    EXPECT_EQ(r.status, 200) << r.body;
    EXPECT_EQ(r.header("content-type"), "text/plain; version=0.0.4; charset=utf-8");
    EXPECT_EQ(r.header("cache-control"), "no-store");
    return test::parseMetrics(r.body);
  }

  std::unique_ptr<ServerProcess> server;
};

TEST_F(MetricsEndpointTest, AskForTheTokenInTheQueryOrABearerHeader) {
  const int port = server->httpPort();
  EXPECT_EQ(test::httpRequest(port, "GET", "/metrics").status, 403);
  EXPECT_EQ(test::httpRequest(port, "GET", "/metrics", {{"Authorization", "Bearer wrong"}}).status, 403);
  EXPECT_EQ(test::httpRequest(port, "GET", "/metrics?token=wrong").status, 403);
  const test::HttpReply query = test::httpRequest(port, "GET", std::string("/metrics?token=") + kMetricsToken);
  EXPECT_EQ(query.status, 200);
  EXPECT_NE(query.body.find("# TYPE voxbrick_frames_total counter"), std::string::npos) << query.body;
  const test::HttpReply head = test::httpRequest(port, "HEAD", std::string("/metrics?token=") + kMetricsToken);
  EXPECT_EQ(head.status, 200);
  EXPECT_TRUE(head.body.empty());
}

TEST_F(MetricsEndpointTest, FiguresFollowWhatClientsDoOnBothTransports) {
  const ParsedMetrics before = scrape();
  EXPECT_EQ(before.value("voxbrick_sessions", R"(transport="tcp")"), 0);
  EXPECT_EQ(before.value("voxbrick_render_threads"), 1);
  EXPECT_EQ(before.value("voxbrick_dragging_sessions"), 0);
  const double framesBefore = before.sum("voxbrick_frames_total");

  client::Client tcp("127.0.0.1", server->port(), std::chrono::seconds(60));
  tcp.hello("metrics-test");
  tcp.openDataset("sparse");
  tcp.render(metricsScene());
  tcp.render(metricsScene());
  tcp.render(metricsScene(R"("batch": true)"));
  int provisional = 0;
  tcp.render(metricsScene(R"("interactive": true, "time_budget_ms": 30)"), proto::Encoding::Png,
             [&provisional](const proto::Frame&) { ++provisional; });
  auto ws = std::make_unique<test::WebSocketClient>(server->httpPort(), std::string("/ws?token=") + kMetricsToken);
  ws->hello();
  ws->openDataset("sparse");
  ws->render(metricsScene(), proto::Encoding::ZstdRgba8);
  // A refused upgrade is a refusal for its token.
  EXPECT_THROW(test::WebSocketClient(server->httpPort(), "/ws?token=wrong"), test::UpgradeRefused);

  const ParsedMetrics p = scrape();
  EXPECT_EQ(p.value("voxbrick_sessions", R"(transport="tcp")"), 1);
  EXPECT_EQ(p.value("voxbrick_sessions", R"(transport="websocket")"), 1);
  EXPECT_GE(p.value("voxbrick_sessions_accepted_total"), 2);
  EXPECT_EQ(p.value("voxbrick_frames_total", R"(class="still",encoding="png")"), 2);
  EXPECT_EQ(p.value("voxbrick_frames_total", R"(class="still",encoding="zstd_rgba8")"), 1);
  EXPECT_EQ(p.value("voxbrick_frames_total", R"(class="batch",encoding="png")"), 1);
  EXPECT_EQ(p.value("voxbrick_frames_total", R"(class="interactive",encoding="png")"), 1)
      << "the interactive request's first frame (provisional: " << provisional << ")";
  EXPECT_EQ(p.sum("voxbrick_frames_total") - framesBefore, 5);
  EXPECT_EQ(p.value("voxbrick_renders_refined_total"), provisional) << "its exact frame, after the provisional one";
  EXPECT_EQ(p.value("voxbrick_render_jobs_total", R"(class="still")"), 3);
  EXPECT_EQ(p.value("voxbrick_render_jobs_total", R"(class="batch")"), 1);
  EXPECT_EQ(p.value("voxbrick_render_jobs_total", R"(class="interactive")"), 1);
  EXPECT_EQ(p.value("voxbrick_render_requests_total"), 5);
  EXPECT_EQ(p.value("voxbrick_frame_latency_seconds_count", R"(class="still")"), 3);
  EXPECT_EQ(p.value("voxbrick_frame_latency_seconds_bucket", R"(class="still",le="+Inf")"), 3);
  EXPECT_GT(p.value("voxbrick_frame_latency_seconds_sum", R"(class="still")"), 0);
  const double frameBytes = p.sum("voxbrick_frame_bytes_total");
  EXPECT_GT(frameBytes, 5 * 100);
  EXPECT_GT(p.value("voxbrick_bytes_written_total"), frameBytes) << "frames and every other reply";
  EXPECT_EQ(p.value("voxbrick_refusals_total", R"(reason="forbidden")"), 1);
  EXPECT_EQ(p.value("voxbrick_refusals_total", R"(reason="busy")"), 0);
  // One interactive Render: the session counts as dragging for a second after it (not asserted: a loaded machine may
  // take longer to get here), and one moving frame measures no capacity yet (sixteen do): no limit.
  EXPECT_FALSE(std::isnan(p.value("voxbrick_dragging_sessions")));
  EXPECT_EQ(p.value("voxbrick_interactive_capacity_sessions"), 0);
  EXPECT_GT(p.value("voxbrick_render_thread_busy_seconds_total", R"(thread="0")"), 0);
  EXPECT_TRUE(std::isnan(p.value("voxbrick_render_thread_busy_seconds_total", R"(thread="1")"))) << "one thread";
  // The thread waited for work before the first job and between them (the clients asked one frame at a time).
  EXPECT_GT(p.value("voxbrick_render_thread_wait_seconds_total", R"(thread="0")"), 0);
  // The Stats JSON says the same, a figure for each render thread (nothing was drawn since the scrape).
  const nlohmann::json stats = nlohmann::json::parse(tcp.stats());
  ASSERT_EQ(stats["render_busy_s"].size(), 1u) << stats.dump();
  EXPECT_EQ(stats["sessions"]["interactive_capacity"], 0) << stats.dump();
  EXPECT_TRUE(stats["sessions"].contains("dragging")) << stats.dump();
  EXPECT_NEAR(stats["render_busy_s"][0].get<double>(),
              p.value("voxbrick_render_thread_busy_seconds_total", R"(thread="0")"), 1e-9);
  ASSERT_EQ(stats["render_wait_s"].size(), 1u) << stats.dump();
  EXPECT_GE(stats["render_wait_s"][0].get<double>(),
            p.value("voxbrick_render_thread_wait_seconds_total", R"(thread="0")"))
      << "still waiting since the scrape";
  EXPECT_GT(p.value("voxbrick_cache_hits_total", R"(dataset="sparse")") +
                p.value("voxbrick_cache_misses_total", R"(dataset="sparse")"),
            0);
  EXPECT_GT(p.value("voxbrick_cache_budget_bytes", R"(dataset="sparse")"), 0);
  EXPECT_EQ(p.value("voxbrick_dataset_quarantined", R"(dataset="sparse")"), 0);
  EXPECT_GT(p.value("voxbrick_gpu_atlas_bytes"), 0);
  EXPECT_GT(p.value("voxbrick_gpu_budget_bytes"), 0);
  EXPECT_GT(p.value("voxbrick_resident_memory_bytes"), 1 << 20);
  EXPECT_GT(p.value("voxbrick_uptime_seconds"), 0);
  EXPECT_GE(p.value("voxbrick_messages_total"), 9) << "two Hellos, two OpenDatasets, five Renders";

  // Every family the live server exposes is in docs/server.md's table, with its type.
  const auto documented = test::documentedMetrics();
  for (const auto& [name, type] : p.types) {
    const auto doc = documented.find(name);
    EXPECT_TRUE(doc != documented.end() && doc->second == type) << name << " (" << type << ") in docs/server.md";
  }

  // Sessions that end leave the gauges.
  tcp.goodbye();
  ws.reset();
  ParsedMetrics after;
  for (int i = 0; i < 100; ++i) {
    after = scrape();
    if (after.sum("voxbrick_sessions") == 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(after.sum("voxbrick_sessions"), 0);
}

// Prometheus keeps its connection alive between scrapes: closed when the next request does not come within the Hello
// timeout, it is idle, not a timeout (which counts connections that never sent a whole request in time).
TEST_F(MetricsEndpointTest, AKeptAliveConnectionClosedIdleIsNoTimeout) {
  start("--hello-timeout 1");
  const std::string request =
      std::string("GET /metrics HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer ") + kMetricsToken + "\r\n\r\n";
  // The three at once, each closed within its own timeout.
  test::RawSocket kept(server->httpPort(), test::Framing::None);
  test::RawSocket silent(server->httpPort(), test::Framing::None);
  test::RawSocket partial(server->httpPort(), test::Framing::None);
  ASSERT_TRUE(kept.sendAll(std::vector<uint8_t>(request.begin(), request.end())));
  const std::string half = "GET /metrics HTTP/1.1\r\nHo";
  ASSERT_TRUE(partial.sendAll(std::vector<uint8_t>(half.begin(), half.end())));
  EXPECT_TRUE(kept.waitClosed(5s)) << "closed once no further request came";
  EXPECT_TRUE(silent.waitClosed(5s));
  EXPECT_TRUE(partial.waitClosed(5s));
  EXPECT_EQ(scrape().value("voxbrick_timeouts_total"), 2) << "the silent connection and the half request";
}

}  // namespace
}  // namespace voxbrick
