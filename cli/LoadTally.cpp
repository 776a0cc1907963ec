// The load's counts and its report: totals, percentiles, per-client figures and Jain's index over them.
#include "cli/LoadTally.h"

#include <algorithm>
#include <cstdio>

namespace voxbrick::cli {

using nlohmann::json;

void Tally::error(const std::string& what, int client) {
  std::lock_guard lock(mutex);
  ++errors;
  if (client >= 0) ++clients[size_t(client)].errors;
  if (errorSamples.size() < 10) errorSamples.push_back(what);
}

void Tally::countFrame(int client, double latencyMs) {
  ClientFigures& c = clients[size_t(client)];
  latencies.push_back(latencyMs);
  c.latencies.push_back(latencyMs);
  ++frames, ++c.frames;
  if (!c.firstFrameS) c.firstFrameS = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
}

void Tally::countBusy(int client) {
  ++busy;
  ++clients[size_t(client)].busy;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(p * double(v.size())))];
}

std::optional<double> jainIndex(const std::vector<double>& x) {
  double sum = 0, squares = 0;
  for (double v : x) sum += v, squares += v * v;
  if (x.empty() || squares <= 0) return std::nullopt;
  return sum * sum / (double(x.size()) * squares);
}

namespace {

/// The slowest frame's rate over the fastest's (the fastest frame's time over the slowest's), in (0, 1]; 0 when
/// there are no frames.
double frameRateRatio(const std::vector<double>& ms) {
  if (ms.empty()) return 0;
  const auto [lo, hi] = std::minmax_element(ms.begin(), ms.end());
  return *hi > 0 ? *lo / *hi : 0;
}

std::vector<double> clientRates(const Tally& tally, double seconds) {
  std::vector<double> rates;
  for (const ClientFigures& c : tally.clients) rates.push_back(double(c.frames) / seconds);
  return rates;
}

json optionalNumber(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

/// {"p10", "p50", "p90"} of `scales`; null when there are none.
json scaleSpread(const std::vector<double>& scales) {
  if (scales.empty()) return nullptr;
  return {{"p10", percentile(scales, 0.1)}, {"p50", percentile(scales, 0.5)}, {"p90", percentile(scales, 0.9)}};
}

/// Each well-behaved client's figures, in index order.
json perClient(const Tally& tally, double seconds) {
  json out = json::array();
  for (size_t i = 0; i < tally.clients.size(); ++i) {
    const ClientFigures& c = tally.clients[i];
    out.push_back(
        {{"client", i},
         {"frames", c.frames},
         {"frames_per_s", double(c.frames) / seconds},
         {"first_frame_s", optionalNumber(c.firstFrameS)},
         // From its first frame to the end: a client let in late is judged by the time it was in.
         {"frames_per_s_since_first",
          c.firstFrameS && seconds - *c.firstFrameS > 0 ? json(double(c.frames) / (seconds - *c.firstFrameS)) : json()},
         {"latency_ms", {{"p50", percentile(c.latencies, 0.5)}, {"p99", percentile(c.latencies, 0.99)}}},
         {"busy", c.busy},
         {"drags_taken", c.dragsTaken},
         {"drags_refused", c.dragsRefused},
         {"drag_wait_ms_max", c.dragWaitsMs.empty() ? json() : json(percentile(c.dragWaitsMs, 1.0))},
         {"errors", c.errors}});
  }
  return out;
}

}  // namespace

json faultCounts(const Tally& tally, int64_t& unexpected) {
  json faults = json::object();
  unexpected = 0;
  for (const auto& [kind, n] : tally.faultsDone) {
    const int64_t bad = tally.faultsUnexpected.count(kind) ? tally.faultsUnexpected.at(kind) : 0;
    faults[kind] = {{"done", n}, {"unexpected", bad}};
    unexpected += bad;
  }
  return faults;
}

namespace {

/// --drag-cycle: the drags taken and refused in all, and the waits for their first frames; null without it.
json dragCycleReport(const LoadArgs& a, const Tally& tally) {
  if (a.dragCycle.size() != 2) return nullptr;
  std::vector<double> waits, releases;
  int64_t taken = 0, refused = 0;
  for (const ClientFigures& c : tally.clients) {
    waits.insert(waits.end(), c.dragWaitsMs.begin(), c.dragWaitsMs.end());
    releases.insert(releases.end(), c.releaseWaitsMs.begin(), c.releaseWaitsMs.end());
    taken += c.dragsTaken, refused += c.dragsRefused;
  }
  const auto spread = [](const std::vector<double>& ms) {
    return json{{"p50", percentile(ms, 0.5)},
                {"p90", percentile(ms, 0.9)},
                {"p99", percentile(ms, 0.99)},
                {"max", percentile(ms, 1.0)}};
  };
  return {{"drag_s", a.dragCycle[0]},      {"rest_s", a.dragCycle[1]}, {"drags_taken", taken},
          {"drags_refused", refused},      {"wait_ms", spread(waits)}, {"releases_answered", releases.size()},
          {"release_ms", spread(releases)}};
}

}  // namespace

json loadReport(const LoadArgs& a, const Tally& tally, double seconds, int width, int height, const json& faults,
                const json& server, const json& serverBefore, const json& scene) {
  const json budget = tally.budgetMs.empty() ? json(nullptr)
                                             : json{{"p50", percentile(tally.budgetMs, 0.5)},
                                                    {"min", percentile(tally.budgetMs, 0.0)},
                                                    {"max", percentile(tally.budgetMs, 1.0)}};
  return {
      {"clients", a.clients},
      {"fault_clients", a.faultClients},
      {"idle_sessions", a.idleSessions},
      {"duration_s", seconds},
      {"size", {width, height}},
      {"frames", tally.frames},
      {"frames_per_s", double(tally.frames) / seconds},
      {"encoding", a.encoding},
      {"payload_bytes_per_frame", tally.frames > 0 ? double(tally.payloadBytes) / double(tally.frames) : 0.0},
      {"errors", tally.errors},
      {"superseded", tally.superseded},
      {"provisional", tally.provisional},
      {"exact_followups", tally.exactFollowUps},
      {"busy", tally.busy},
      {"batch", a.batch},
      {"batch_refused", tally.batchRefused},
      {"protocol_version", tally.protocolVersion},
      {"scene", scene},
      {"drag_hz", a.dragHz},
      {"drag_cycle", dragCycleReport(a, tally)},
      {"error_samples", tally.errorSamples},
      {"latency_ms",
       {{"p50", percentile(tally.latencies, 0.5)},
        {"p95", percentile(tally.latencies, 0.95)},
        {"p99", percentile(tally.latencies, 0.99)},
        {"max", percentile(tally.latencies, 1.0)}}},
      {"time_budget_ms", budget},
      {"provisional_encoding", a.provisionalEncoding.empty() ? json() : json(a.provisionalEncoding)},
      {"encode_ms_p50", tally.encodeMs.empty() ? json() : json(percentile(tally.encodeMs, 0.5))},
      // Interactive frames: the drawing's and the video stream's sides as fractions of the scene's (p10, p50, p90).
      {"drawn_scale", scaleSpread(tally.drawnScale)},
      {"sent_scale", scaleSpread(tally.sentScale)},
      // Interactive frames chosen by a known rate: their predicted and actual time, ms (medians).
      {"interactive_ms", tally.predictedMs.empty() ? json()
                                                   : json{{"predicted_p50", percentile(tally.predictedMs, 0.5)},
                                                          {"actual_p50", percentile(tally.actualMs, 0.5)}}},
      {"video", tally.videoFrames == 0
                    ? json()
                    : json{{"frames", tally.videoFrames},
                           {"key_frames", tally.keyFrames},
                           {"frames_444", tally.fullChromaFrames},
                           {"decode_ms",
                            {{"p50", percentile(tally.decodeMs, 0.5)}, {"p99", percentile(tally.decodeMs, 0.99)}}}}},
      {"render_ms_p50", percentile(tally.renderMs, 0.5)},
      // Over the orbit the clients turn through (warm frames): the slowest frame against the fastest.
      {"warm_render_ms", {{"min", percentile(tally.renderMsWarm, 0.0)}, {"max", percentile(tally.renderMsWarm, 1.0)}}},
      {"frame_rate_min_over_max", frameRateRatio(tally.renderMsWarm)},
      {"per_client", perClient(tally, seconds)},
      {"jain_index", optionalNumber(jainIndex(clientRates(tally, seconds)))},
      {"faults", faults},
      {"server", server},
      {"server_before", serverBefore}};
}

void printSummary(const LoadArgs& a, const Tally& tally, double seconds, int64_t unexpected, const json& server) {
  std::printf(
      "load: %d clients (+%d faulty, %d idle) for %.1f s: %lld frames, %.1f frames/s, latency p50 %.1f "
      "p95 %.1f p99 %.1f max %.1f ms, %lld superseded, %lld busy, %lld errors, %lld unexpected fault replies",
      a.clients, a.faultClients, a.idleSessions, seconds, (long long)tally.frames, double(tally.frames) / seconds,
      percentile(tally.latencies, 0.5), percentile(tally.latencies, 0.95), percentile(tally.latencies, 0.99),
      percentile(tally.latencies, 1.0), (long long)tally.superseded, (long long)tally.busy, (long long)tally.errors,
      (long long)unexpected);
  if (const auto jain = jainIndex(clientRates(tally, seconds)); jain && tally.clients.size() > 1)
    std::printf(", Jain's index over clients %.3f", *jain);
  if (!tally.renderMsWarm.empty())
    std::printf(", warm frames %.1f-%.1f ms (min/max frame rate 1:%.2f)", percentile(tally.renderMsWarm, 0.0),
                percentile(tally.renderMsWarm, 1.0), 1 / frameRateRatio(tally.renderMsWarm));
  if (server.contains("memory"))
    std::printf(", server RSS %.0f MB (peak %.0f MB)", double(server["memory"]["rss_bytes"]) / 1e6,
                double(server["memory"]["peak_rss_bytes"]) / 1e6);
  if (tally.videoFrames > 0)
    std::printf(", %lld video frames (%lld key), decoded in %.2f ms (p50)", (long long)tally.videoFrames,
                (long long)tally.keyFrames, percentile(tally.decodeMs, 0.5));
  if (const json cycle = dragCycleReport(a, tally); !cycle.is_null())
    std::printf(
        ", drags taken %lld (refused throughout %lld), first frame after p50 %.0f p99 %.0f max %.0f ms, "
        "release to its frame p50 %.0f p99 %.0f max %.0f ms",
        (long long)cycle["drags_taken"].get<int64_t>(), (long long)cycle["drags_refused"].get<int64_t>(),
        cycle["wait_ms"]["p50"].get<double>(), cycle["wait_ms"]["p99"].get<double>(),
        cycle["wait_ms"]["max"].get<double>(), cycle["release_ms"]["p50"].get<double>(),
        cycle["release_ms"]["p99"].get<double>(), cycle["release_ms"]["max"].get<double>());
  if (tally.batchRefused > 0)
    std::printf(", %lld clients sent no batch key (the server does not know it)", (long long)tally.batchRefused);
  std::printf("\n");
  for (const std::string& e : tally.errorSamples) std::printf("  error: %s\n", e.c_str());
}

}  // namespace voxbrick::cli
