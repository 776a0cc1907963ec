// The Prometheus text of /metrics without a server: the writer (families, samples, escaping, histograms), the
// histogram's buckets, the server's statistics as families, and docs/server.md's table of them.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "PrometheusText.h"
#include "server/Metrics.h"
#include "server/ServerStats.h"

namespace voxbrick::server {
namespace {

using test::familyOfSample;
using test::ParsedMetrics;
using test::parseMetrics;
using test::SampleLine;

TEST(MetricsText, WritesFamiliesSamplesAndEscapedLabels) {
  MetricsText m;
  m.family("demo_requests_total", MetricsText::Type::Counter, "Requests, with a \\ and a\nline break.")
      .sample(3, {{"path", "a\"b\\c\nd"}, {"code", "200"}})
      .sample(0);
  m.family("demo_temperature", MetricsText::Type::Gauge, "A gauge.").sample(-1.5).sample(0.1, {{"room", "x"}});
  EXPECT_EQ(m.text(),
            "# HELP demo_requests_total Requests, with a \\\\ and a\\nline break.\n"
            "# TYPE demo_requests_total counter\n"
            "demo_requests_total{path=\"a\\\"b\\\\c\\nd\",code=\"200\"} 3\n"
            "demo_requests_total 0\n"
            "# HELP demo_temperature A gauge.\n"
            "# TYPE demo_temperature gauge\n"
            "demo_temperature -1.5\n"
            "demo_temperature{room=\"x\"} 0.1\n");
  EXPECT_EQ(m.families(), (std::vector<std::string>{"demo_requests_total", "demo_temperature"}));
  const ParsedMetrics parsed = parseMetrics(m.text());
  EXPECT_EQ(parsed.samples.size(), 4u);
  EXPECT_EQ(parsed.value("demo_requests_total", R"(path="a\"b\\c\nd",code="200")"), 3);
}

TEST(MetricsText, FormatsValuesAsTheFormatSpellsThem) {
  EXPECT_EQ(MetricsText::formatValue(0), "0");
  EXPECT_EQ(MetricsText::formatValue(42), "42");
  EXPECT_EQ(MetricsText::formatValue(1ull << 40), "1099511627776");
  EXPECT_EQ(MetricsText::formatValue(0.005), "0.005");
  EXPECT_EQ(MetricsText::formatValue(-2.25), "-2.25");
  EXPECT_EQ(MetricsText::formatValue(1e300), "1e+300");
  EXPECT_EQ(MetricsText::formatValue(1.0 / 0.0), "+Inf");
  EXPECT_EQ(MetricsText::formatValue(-1.0 / 0.0), "-Inf");
  EXPECT_EQ(MetricsText::formatValue(std::nan("")), "NaN");
  EXPECT_EQ(MetricsText::escapeLabelValue("plain"), "plain");
  EXPECT_EQ(MetricsText::escapeLabelValue("q\"b\\n\n"), "q\\\"b\\\\n\\n");
}

TEST(MetricsText, RefusesMisuse) {
  MetricsText m;
  EXPECT_THROW(m.sample(1), std::logic_error) << "a sample before any family";
  EXPECT_THROW(m.family("9lives", MetricsText::Type::Gauge, ""), std::invalid_argument);
  EXPECT_THROW(m.family("has space", MetricsText::Type::Gauge, ""), std::invalid_argument);
  EXPECT_THROW(m.family("demo_requests", MetricsText::Type::Counter, ""), std::invalid_argument)
      << "a counter's name ends in _total";
  m.family("demo_g", MetricsText::Type::Gauge, "");
  EXPECT_THROW(m.family("demo_g", MetricsText::Type::Gauge, ""), std::invalid_argument) << "written twice";
  EXPECT_THROW(m.sample(1, {{"le", "1"}}), std::invalid_argument) << "le is the histogram's";
  EXPECT_THROW(m.sample(1, {{"__name", "x"}}), std::invalid_argument) << "reserved";
  EXPECT_THROW(m.sample(1, {{"a-b", "x"}}), std::invalid_argument);
  EXPECT_THROW(m.histogram(HistogramCounts{{}, {0}, 0}), std::logic_error) << "a gauge family";
  m.family("demo_h", MetricsText::Type::Histogram, "");
  EXPECT_THROW(m.sample(1), std::logic_error) << "a histogram family";
  EXPECT_THROW(m.histogram(HistogramCounts{{1, 2}, {0, 0}, 0}), std::invalid_argument) << "one count short";
  EXPECT_THROW(Histogram(std::vector<double>{1, 1}), std::invalid_argument);
  EXPECT_THROW(Histogram(std::vector<double>{2, 1}), std::invalid_argument);
  EXPECT_THROW(Histogram(std::vector<double>{1, 1.0 / 0.0}), std::invalid_argument);
}

TEST(Histogram, CountsIntoCumulativeBucketsWithSumAndCount) {
  const std::vector<double> bounds = {0.01, 0.1, 1};
  Histogram h(bounds);
  for (const double v : {0.001, 0.01, 0.05, 0.1, 0.5, 3.0, 7.0, std::nan("")}) h.observe(v);
  const HistogramCounts c = h.counts();
  EXPECT_EQ(c.cumulative, (std::vector<uint64_t>{2, 4, 5, 7})) << "a value equal to a bound is in its bucket";
  EXPECT_EQ(c.count(), 7u) << "NaN is not counted";
  EXPECT_DOUBLE_EQ(c.sum, 0.001 + 0.01 + 0.05 + 0.1 + 0.5 + 3.0 + 7.0);

  MetricsText m;
  m.family("demo_seconds", MetricsText::Type::Histogram, "Latency.").histogram(c, {{"class", "still"}});
  EXPECT_EQ(m.text(),
            "# HELP demo_seconds Latency.\n"
            "# TYPE demo_seconds histogram\n"
            "demo_seconds_bucket{class=\"still\",le=\"0.01\"} 2\n"
            "demo_seconds_bucket{class=\"still\",le=\"0.1\"} 4\n"
            "demo_seconds_bucket{class=\"still\",le=\"1\"} 5\n"
            "demo_seconds_bucket{class=\"still\",le=\"+Inf\"} 7\n"
            "demo_seconds_sum{class=\"still\"} " +
                MetricsText::formatValue(c.sum) +
                "\n"
                "demo_seconds_count{class=\"still\"} 7\n");
}

TEST(Histogram, ManyThreadsObserveWithoutLosingCounts) {
  Histogram h(std::vector<double>{0.5});
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&h, t] {
      for (int i = 0; i < 20000; ++i) h.observe(t % 2 ? 1.0 : 0.25);
    });
  for (std::thread& t : threads) t.join();
  const HistogramCounts c = h.counts();
  EXPECT_EQ(c.cumulative, (std::vector<uint64_t>{40000, 80000}));
  EXPECT_DOUBLE_EQ(c.sum, 40000 * 1.0 + 40000 * 0.25);
}

TEST(ServerMetrics, EveryFamilyHasHelpAndTypeAndEverySampleAFamily) {
  ServerStats stats;
  ServerStats::Gauges gauges;
  gauges.deviceBusyMs = {1500, 250};
  gauges.deviceWaitMs = {500, 2750};
  gauges.tcpSessions = 2;
  gauges.webSocketSessions = 1;
  gauges.queuedByClass = {3, 0, 7};
  gauges.encodesByClass = {1, 4, 0};
  const ParsedMetrics parsed = parseMetrics(stats.metricsText(gauges));
  ASSERT_GT(parsed.types.size(), 30u);
  for (const SampleLine& s : parsed.samples)
    EXPECT_NE(familyOfSample(s.name, parsed.types), "") << s.name << " belongs to no declared family";
  for (const auto& [name, type] : parsed.types) {
    EXPECT_TRUE(name.starts_with("voxbrick_")) << name;
    if (type == "counter") {
      EXPECT_TRUE(name.ends_with("_total")) << name;
    }
  }
  EXPECT_EQ(parsed.value("voxbrick_render_thread_busy_seconds_total", R"(thread="0")"), 1.5);
  EXPECT_EQ(parsed.value("voxbrick_render_thread_busy_seconds_total", R"(thread="1")"), 0.25);
  EXPECT_EQ(parsed.value("voxbrick_render_thread_wait_seconds_total", R"(thread="0")"), 0.5);
  EXPECT_EQ(parsed.value("voxbrick_render_thread_wait_seconds_total", R"(thread="1")"), 2.75);
  EXPECT_EQ(parsed.value("voxbrick_sessions", R"(transport="tcp")"), 2);
  EXPECT_EQ(parsed.value("voxbrick_sessions", R"(transport="websocket")"), 1);
  EXPECT_EQ(parsed.value("voxbrick_queue_depth", R"(class="interactive")"), 3);
  EXPECT_EQ(parsed.value("voxbrick_queue_depth", R"(class="batch")"), 7);
  EXPECT_EQ(parsed.value("voxbrick_encode_queue_depth", R"(class="still")"), 4);
  EXPECT_GT(parsed.value("voxbrick_resident_memory_bytes"), 1 << 20) << "this process's, from /proc";
}

TEST(ServerMetrics, FramesAreCountedByClassAndEncodingWithTheirLatencyAndBytes) {
  ServerStats stats;
  stats.frameDelivered(FrameClass::Interactive, proto::Encoding::Jpeg, 1000, 20);
  stats.frameDelivered(FrameClass::Interactive, proto::Encoding::Jpeg, 3000, 60);
  stats.frameDelivered(FrameClass::Still, proto::Encoding::Png, 50000, 400);
  stats.frameDelivered(FrameClass::Batch, proto::Encoding::ZstdRgba8, 70000, 12000);
  stats.frameDelivered(FrameClass::Still, proto::Encoding::Webp, 30000, 300);
  stats.renderAccepted(FrameClass::Still);
  stats.renderAccepted(FrameClass::Interactive);
  stats.renderAccepted(FrameClass::Interactive);
  stats.frameShared();
  stats.bytesWritten(123);
  stats.bytesWritten(877);
  const ParsedMetrics p = parseMetrics(stats.metricsText({}));
  EXPECT_EQ(p.value("voxbrick_frames_total", R"(class="interactive",encoding="jpeg")"), 2);
  EXPECT_EQ(p.value("voxbrick_frames_total", R"(class="interactive",encoding="png")"), 0) << "every pair is written";
  EXPECT_EQ(p.value("voxbrick_frames_total", R"(class="still",encoding="png")"), 1);
  EXPECT_EQ(p.value("voxbrick_frames_total", R"(class="batch",encoding="zstd_rgba8")"), 1);
  EXPECT_EQ(p.value("voxbrick_frames_total", R"(class="still",encoding="webp")"), 1) << "every encoding apart";
  EXPECT_EQ(p.value("voxbrick_frames_total", R"(class="still",encoding="vp9")"), 0);
  EXPECT_EQ(p.value("voxbrick_frame_bytes_total", R"(class="interactive",encoding="jpeg")"), 4000);
  EXPECT_EQ(p.value("voxbrick_frame_bytes_total", R"(class="batch",encoding="zstd_rgba8")"), 70000);
  EXPECT_EQ(p.value("voxbrick_render_jobs_total", R"(class="interactive")"), 2);
  EXPECT_EQ(p.value("voxbrick_render_jobs_total", R"(class="still")"), 1);
  EXPECT_EQ(p.value("voxbrick_frames_shared_total"), 1);
  EXPECT_EQ(p.value("voxbrick_bytes_written_total"), 1000);
  // Latencies in seconds: 0.02 and 0.06 for interactive frames, 0.4 still, 12 batch (past the last bound).
  EXPECT_EQ(p.value("voxbrick_frame_latency_seconds_bucket", R"(class="interactive",le="0.025")"), 1);
  EXPECT_EQ(p.value("voxbrick_frame_latency_seconds_bucket", R"(class="interactive",le="0.075")"), 2);
  EXPECT_EQ(p.value("voxbrick_frame_latency_seconds_count", R"(class="interactive")"), 2);
  EXPECT_NEAR(p.value("voxbrick_frame_latency_seconds_sum", R"(class="interactive")"), 0.08, 1e-12);
  EXPECT_EQ(p.value("voxbrick_frame_latency_seconds_bucket", R"(class="still",le="0.25")"), 0);
  EXPECT_EQ(p.value("voxbrick_frame_latency_seconds_bucket", R"(class="still",le="0.5")"), 2);
  EXPECT_EQ(p.value("voxbrick_frame_latency_seconds_bucket", R"(class="batch",le="10")"), 0);
  EXPECT_EQ(p.value("voxbrick_frame_latency_seconds_bucket", R"(class="batch",le="+Inf")"), 1);
  // The Stats JSON keeps its totals and gains the classes.
  const nlohmann::json j = stats.toJson({});
  EXPECT_EQ(j["renders"]["frames"], 5);
  EXPECT_EQ(j["renders"]["frames_by_class"]["interactive"], 2);
  EXPECT_EQ(j["renders"]["accepted_by_class"]["still"], 1);
  EXPECT_EQ(j["renders"]["frames_shared"], 1);
  EXPECT_EQ(j["output"]["bytes_written"], 1000);
  EXPECT_EQ(j["latency_ms"]["samples"], 5);
}

TEST(ServerMetrics, RefusalsAreCountedByReasonAndInTheStatsTotals) {
  ServerStats stats;
  stats.refused(Refusal::Busy);
  stats.refused(Refusal::Busy);
  stats.refused(Refusal::Quota);
  stats.refused(Refusal::Address);
  stats.refused(Refusal::Forbidden);
  stats.refused(Refusal::PendingEvicted);
  stats.add(ServerEvent::SessionRefused);  // counted as before, as a session refused for max_sessions
  stats.add(ServerEvent::OutputRefused);
  EXPECT_EQ(stats.refusals(Refusal::Busy), 2u);
  EXPECT_EQ(stats.refusals(Refusal::Sessions), 1u);
  EXPECT_EQ(stats.refusals(Refusal::Output), 1u);
  EXPECT_EQ(stats.total(ServerEvent::SessionRefused), 3u) << "sessions, address and forbidden";
  EXPECT_EQ(stats.total(ServerEvent::PendingEvicted), 1u);
  const ParsedMetrics p = parseMetrics(stats.metricsText({}));
  const std::map<std::string, double> expected = {{"sessions", 1}, {"address", 1},  {"pending_evicted", 1},
                                                  {"output", 1},   {"busy", 2},     {"quota", 1},
                                                  {"stopping", 0}, {"forbidden", 1}};
  for (const auto& [reason, n] : expected)
    EXPECT_EQ(p.value("voxbrick_refusals_total", "reason=\"" + reason + "\""), n) << reason;
  const nlohmann::json j = stats.toJson({});
  EXPECT_EQ(j["sessions"]["refused"], 3);
  EXPECT_EQ(j["refusals"]["busy"], 2);
  EXPECT_EQ(j["output"]["frames_refused"], 1);
}

TEST(ServerMetrics, VideoFramesAreCountedByCodecAndKeyFramesAndSmallerFramesByReason) {
  ServerStats stats;
  stats.videoEncoded(proto::Encoding::Vp8, 4, "start");
  stats.videoEncoded(proto::Encoding::Vp8, 12, "");
  stats.videoEncoded(proto::Encoding::Vp8, 30, "asked");
  stats.videoEncoded(proto::Encoding::Vp9, 60, "size");
  stats.videoEncoded(proto::Encoding::Vp9, 2, "something new");  // an unknown reason counts as the encoder's
  stats.videoEncoded(proto::Encoding::Vp9, 5, "", VideoScaledFor::Encoders);
  stats.videoEncoded(proto::Encoding::Vp9, 5, "size", VideoScaledFor::Encoders);
  stats.videoEncoded(proto::Encoding::Vp8, 6, "", VideoScaledFor::Link);
  stats.videoEncoded(proto::Encoding::Vp9, 5, "", VideoScaledFor::Memory);
  const ParsedMetrics p = parseMetrics(stats.metricsText({}));
  EXPECT_EQ(p.value("voxbrick_video_encode_seconds_count", R"(codec="vp8")"), 4);
  EXPECT_EQ(p.value("voxbrick_video_encode_seconds_bucket", R"(codec="vp8",le="0.005")"), 1);
  EXPECT_EQ(p.value("voxbrick_video_encode_seconds_bucket", R"(codec="vp8",le="0.01")"), 2);
  EXPECT_EQ(p.value("voxbrick_video_encode_seconds_bucket", R"(codec="vp8",le="0.02")"), 3);
  EXPECT_EQ(p.value("voxbrick_video_encode_seconds_bucket", R"(codec="vp8",le="0.035")"), 4);
  EXPECT_NEAR(p.value("voxbrick_video_encode_seconds_sum", R"(codec="vp8")"), 0.052, 1e-12);
  EXPECT_EQ(p.value("voxbrick_video_encode_seconds_count", R"(codec="vp9")"), 5);
  EXPECT_EQ(p.value("voxbrick_video_encode_seconds_bucket", R"(codec="vp9",le="0.05")"), 4);
  EXPECT_EQ(p.value("voxbrick_video_key_frames_total", R"(reason="start")"), 1);
  EXPECT_EQ(p.value("voxbrick_video_key_frames_total", R"(reason="asked")"), 1);
  EXPECT_EQ(p.value("voxbrick_video_key_frames_total", R"(reason="size")"), 2);
  EXPECT_EQ(p.value("voxbrick_video_key_frames_total", R"(reason="encoder")"), 1);
  EXPECT_EQ(p.value("voxbrick_video_key_frames_total", R"(reason="recovery")"), 0) << "every reason is written";
  // Frames sent smaller than their scene, by why.
  EXPECT_EQ(p.value("voxbrick_video_scaled_frames_total", R"(reason="encoders")"), 2);
  EXPECT_EQ(p.value("voxbrick_video_scaled_frames_total", R"(reason="link")"), 1);
  EXPECT_EQ(p.value("voxbrick_video_scaled_frames_total", R"(reason="memory")"), 1);
  const nlohmann::json video = stats.toJson({})["video"];
  EXPECT_EQ(video["scaled_frames"]["encoders"], 2) << video.dump();
  EXPECT_EQ(video["scaled_frames"]["link"], 1) << video.dump();
  EXPECT_EQ(video["scaled_frames"]["memory"], 1) << video.dump();
}

TEST(ServerMetrics, DocsListEveryFamilyTheServerExposesWithItsType) {
  ServerStats stats;
  const ParsedMetrics p = parseMetrics(stats.metricsText({}));
  const std::map<std::string, std::string> documented = test::documentedMetrics();
  for (const auto& [name, type] : p.types) {
    const auto doc = documented.find(name);
    if (doc == documented.end())
      ADD_FAILURE() << name << " is not in docs/server.md's table of metrics";
    else
      EXPECT_EQ(doc->second, type) << name << "'s type in docs/server.md";
  }
  for (const auto& [name, type] : documented)
    EXPECT_TRUE(p.types.count(name)) << name << " is in docs/server.md but the server does not expose it";
}

}  // namespace
}  // namespace voxbrick::server
