// Statistics counters and the Stats JSON.
#include "server/ServerStats.h"

#include <fstream>
#include <string>
#include <utility>

namespace voxbrick::server {
namespace {

using nlohmann::json;

/// Resident and peak resident memory of this process, in bytes (0 where /proc is unavailable).
std::pair<uint64_t, uint64_t> residentMemory() {
  std::ifstream status("/proc/self/status");
  std::string line;
  uint64_t rss = 0, peak = 0;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) rss = std::stoull(line.substr(6)) * 1024;
    if (line.rfind("VmHWM:", 0) == 0) peak = std::stoull(line.substr(6)) * 1024;
  }
  return {rss, peak};
}

json datasetJson(const render::Dataset& dataset) {
  const store::CacheStats c = dataset.cacheStats();
  const double lookups = double(c.hits + c.misses);
  return {{"name", dataset.name()},
          {"cache",
           {{"hits", c.hits},
            {"misses", c.misses},
            {"hit_rate", lookups > 0 ? double(c.hits) / lookups : 0.0},
            {"resident_bytes", c.residentBytes},
            {"peak_resident_bytes", c.peakResidentBytes},
            {"budget_bytes", c.budgetBytes},
            {"evictions", c.evictions}}},
          {"quarantined", dataset.quarantined() ? json(*dataset.quarantined()) : json(nullptr)}};
}

}  // namespace

void ServerStats::frameDelivered(double latencyMs) {
  add(ServerEvent::Frame);
  mLatency.record(latencyMs);
}

json ServerStats::toJson(const Gauges& gauges) const {
  const auto [rss, peak] = residentMemory();
  json sets = json::array();
  for (const auto& dataset : gauges.datasets) sets.push_back(datasetJson(*dataset));
  const double uptime = std::chrono::duration<double>(std::chrono::steady_clock::now() - mStarted).count();
  const uint64_t frames = total(ServerEvent::Frame);
  return {{"uptime_s", uptime},
          {"sessions",
           {{"active", gauges.activeSessions},
            {"pending", gauges.pendingConnections},
            {"accepted", total(ServerEvent::SessionAccepted)},
            {"refused", total(ServerEvent::SessionRefused)},
            {"evicted", total(ServerEvent::PendingEvicted)},
            {"timed_out", total(ServerEvent::Timeout)},
            {"dropped_slow", total(ServerEvent::SlowClientDropped)}}},
          {"messages", total(ServerEvent::Message)},
          {"protocol_errors", total(ServerEvent::ProtocolError)},
          {"renders",
           {{"requested", total(ServerEvent::RenderRequest)},
            {"frames", frames},
            {"superseded", total(ServerEvent::Superseded)},
            {"refined", total(ServerEvent::Refined)},
            {"errors", total(ServerEvent::RenderError)},
            {"cancelled", gauges.rendersCancelled},
            {"queued", gauges.queuedSessions},
            {"frames_per_s", uptime > 0 ? double(frames) / uptime : 0.0}}},
          {"latency_ms", mLatency.toJson()},
          {"datasets", sets},
          {"memory", {{"rss_bytes", rss}, {"peak_rss_bytes", peak}}},
          {"output",
           {{"queued_bytes", gauges.outputQueuedBytes},
            {"peak_queued_bytes", gauges.outputPeakBytes},
            {"limit_bytes", gauges.outputLimitBytes},
            {"reading_paused", total(ServerEvent::ReadingPaused)},
            {"frames_refused", total(ServerEvent::OutputRefused)}}},
          {"gpu",
           {{"budget_bytes", gauges.gpuBudgetBytes},
            {"atlas_bytes", gauges.gpu.bytes},
            {"peak_atlas_bytes", gauges.gpu.peakBytes},
            {"renderers_released", gauges.gpu.renderersReleased}}},
          {"limits", gauges.limits},
          {"render_threads", gauges.renderThreads}};
}

}  // namespace voxbrick::server
