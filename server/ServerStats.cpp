// Statistics counters, the Stats JSON and the Prometheus text.
#include "server/ServerStats.h"

#include <algorithm>
#include <fstream>
#include <optional>
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

/// The refusal an event counted through add() is.
std::optional<Refusal> refusalOf(ServerEvent event) {
  switch (event) {
    case ServerEvent::SessionRefused: return Refusal::Sessions;
    case ServerEvent::PendingEvicted: return Refusal::PendingEvicted;
    case ServerEvent::OutputRefused: return Refusal::Output;
    default: return std::nullopt;
  }
}

/// The event a refusal counts as, if any (busy and quota are new to the Stats JSON: it has its own figures for them).
std::optional<ServerEvent> eventOf(Refusal reason) {
  switch (reason) {
    case Refusal::Sessions:
    case Refusal::Address:
    case Refusal::Stopping:
    case Refusal::Forbidden: return ServerEvent::SessionRefused;
    case Refusal::PendingEvicted: return ServerEvent::PendingEvicted;
    case Refusal::Output: return ServerEvent::OutputRefused;
    case Refusal::Busy:
    case Refusal::Quota:
    case Refusal::Tls: return std::nullopt;
  }
  return std::nullopt;
}

}  // namespace

void ServerStats::add(ServerEvent event) {
  mCounts[size_t(event)]++;
  if (const auto reason = refusalOf(event)) mRefusals[size_t(*reason)]++;
}

void ServerStats::refused(Refusal reason) {
  mRefusals[size_t(reason)]++;
  if (const auto event = eventOf(reason)) mCounts[size_t(*event)]++;
}

void ServerStats::renderAccepted(FrameClass frameClass) { mAccepted[size_t(frameClass)]++; }

void ServerStats::frameDelivered(FrameClass frameClass, proto::Encoding encoding, uint64_t bytes, double latencyMs) {
  mCounts[size_t(ServerEvent::Frame)]++;
  const size_t c = size_t(frameClass), e = std::min(size_t(encoding), kFrameEncodings - 1);
  mFrames[c][e]++;
  mFrameBytes[c][e] += bytes;
  mLatencyByClass[c].observe(latencyMs / 1000);
  mLatency.record(latencyMs);
}

void ServerStats::videoEncoded(proto::Encoding codec, double encodeMs, std::string_view keyReason,
                               VideoScaledFor scaledFor) {
  mVideoEncode[codec == proto::Encoding::Vp9 ? 1 : 0].observe(encodeMs / 1000);
  if (scaledFor != VideoScaledFor::None) mVideoScaled[size_t(scaledFor)]++;
  if (keyReason.empty()) return;
  const auto* at = std::find(kVideoKeyReasons.begin(), kVideoKeyReasons.end(), keyReason);
  mVideoKeyFrames[at == kVideoKeyReasons.end() ? kVideoKeyReasons.size() - 1 : size_t(at - kVideoKeyReasons.begin())]++;
}

json ServerStats::toJson(const Gauges& gauges) const {
  const auto [rss, peak] = residentMemory();
  json sets = json::array();
  for (const auto& dataset : gauges.datasets) sets.push_back(datasetJson(*dataset));
  const double uptime = std::chrono::duration<double>(std::chrono::steady_clock::now() - mStarted).count();
  const uint64_t frames = total(ServerEvent::Frame);
  json accepted = json::object(), framesByClass = json::object();
  for (const FrameClass c : kAllFrameClasses) {
    accepted[common::nameOf(c)] = mAccepted[size_t(c)].load();
    uint64_t n = 0;
    for (const auto& count : mFrames[size_t(c)]) n += count.load();
    framesByClass[common::nameOf(c)] = n;
  }
  json refusals = json::object();
  for (const auto& entry : kRefusalNames) refusals[entry.name] = this->refusals(entry.value);
  // Each render thread's seconds drawing and encoding, and asking for its next job, since it started (as /metrics'
  // busy and wait counters).
  const auto seconds = [](const std::vector<double>& ms) {
    json out = json::array();
    for (const double v : ms) out.push_back(v / 1000);
    return out;
  };
  return {{"uptime_s", uptime},
          {"sessions",
           {{"active", gauges.activeSessions},
            {"pending", gauges.pendingConnections},
            {"accepted", total(ServerEvent::SessionAccepted)},
            {"refused", total(ServerEvent::SessionRefused)},
            {"evicted", total(ServerEvent::PendingEvicted)},
            {"tcp", gauges.tcpSessions},
            {"websocket", gauges.webSocketSessions},
            {"dragging", gauges.draggingSessions},
            {"interactive_capacity", gauges.interactiveCapacity},
            {"waiting_to_drag", gauges.waitingToDrag},
            {"drag_turns_ended", gauges.dragTurnsEnded},
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
            {"frames_per_s", uptime > 0 ? double(frames) / uptime : 0.0},
            {"accepted_by_class", accepted},
            {"frames_by_class", framesByClass},
            {"frames_shared", mFramesShared.load()}}},
          {"refusals", refusals},
          {"latency_ms", mLatency.toJson()},
          {"datasets", sets},
          {"memory", {{"rss_bytes", rss}, {"peak_rss_bytes", peak}}},
          {"output",
           {{"queued_bytes", gauges.outputQueuedBytes},
            {"peak_queued_bytes", gauges.outputPeakBytes},
            {"limit_bytes", gauges.outputLimitBytes},
            {"reading_paused", total(ServerEvent::ReadingPaused)},
            {"frames_refused", total(ServerEvent::OutputRefused)},
            {"bytes_written", mBytesOut.load()}}},
          {"gpu",
           {{"budget_bytes", gauges.gpuBudgetBytes},
            {"atlas_bytes", gauges.gpu.bytes},
            {"peak_atlas_bytes", gauges.gpu.peakBytes},
            {"renderers_released", gauges.gpu.renderersReleased}}},
          {"video", videoJson(gauges.video)},
          {"uploads", {{"done", total(ServerEvent::Uploaded)}, {"refused", total(ServerEvent::UploadRefused)}}},
          {"limits", gauges.limits},
          {"render_threads", gauges.renderThreads},
          {"render_busy_s", seconds(gauges.deviceBusyMs)},
          {"render_wait_s", seconds(gauges.deviceWaitMs)}};
}

json ServerStats::videoJson(const Gauges::Video& memory) const {
  json keys = json::object(), encoded = json::object();
  for (size_t i = 0; i < kVideoKeyReasons.size(); ++i) keys[std::string(kVideoKeyReasons[i])] = mVideoKeyFrames[i].load();
  json scaled = json::object();
  for (const auto& [why, name] : kVideoScaledForNames)
    if (why != VideoScaledFor::None) scaled[name] = mVideoScaled[size_t(why)].load();
  for (const auto& [i, codec] : {std::pair{0, "vp8"}, std::pair{1, "vp9"}}) {
    const HistogramCounts c = mVideoEncode[size_t(i)].counts();
    encoded[codec] = {{"frames", c.count()}, {"encode_ms_mean", c.count() ? 1000 * c.sum / double(c.count()) : 0.0}};
  }
  return {{"encoded", encoded},
          {"key_frames", keys},
          {"scaled_frames", scaled},
          {"encoders", memory.encoders},
          {"memory_bytes", memory.bytes},
          {"memory_peak_bytes", memory.peakBytes},
          {"memory_limit_bytes", memory.limitBytes},
          {"encoders_freed", memory.freed},
          {"jpeg_frames", memory.jpegFrames}};
}

std::string ServerStats::metricsText(const Gauges& gauges) const {
  using Type = MetricsText::Type;
  MetricsText m;
  const auto [rss, peak] = residentMemory();
  const double uptime = std::chrono::duration<double>(std::chrono::steady_clock::now() - mStarted).count();
  const auto one = [&m](std::string_view name, Type type, std::string_view help, double value) {
    m.family(name, type, help).sample(value);
  };
  const auto event = [&](std::string_view name, std::string_view help, ServerEvent e) {
    one(name, Type::Counter, help, double(total(e)));
  };
  const auto byClass = [](FrameClass c) { return MetricLabels{{"class", common::nameOf(c)}}; };

  one("voxbrick_uptime_seconds", Type::Gauge, "Seconds since the server started.", uptime);
  one("voxbrick_render_threads", Type::Gauge, "Render threads, each with its own GL context.", gauges.renderThreads);

  // Connections and sessions.
  m.family("voxbrick_sessions", Type::Gauge, "Open sessions (connections whose Hello was accepted), by transport.")
      .sample(double(gauges.tcpSessions), {{"transport", "tcp"}})
      .sample(double(gauges.webSocketSessions), {{"transport", "websocket"}});
  one("voxbrick_pending_connections", Type::Gauge, "Connections accepted that have not said Hello yet.",
      double(gauges.pendingConnections));
  one("voxbrick_dragging_sessions", Type::Gauge, "Sessions that sent an interactive Render within the last second.",
      double(gauges.draggingSessions));
  one("voxbrick_interactive_capacity_sessions", Type::Gauge,
      "Sessions that may drag before a new session is answered Busy: max_interactive_sessions, else measured from "
      "what a moving frame costs the render threads; 0 until measured (no limit).",
      double(gauges.interactiveCapacity));
  one("voxbrick_waiting_to_drag_sessions", Type::Gauge,
      "Sessions whose first moving camera was answered Busy, in line to drag: room that opens goes to them in turn.",
      double(gauges.waitingToDrag));
  one("voxbrick_drag_turns_ended_total", Type::Counter,
      "Drags whose turn ended: a session that dragged interactive_turn_s without letting go while others waited in "
      "line, told Busy and put at the back of it.",
      double(gauges.dragTurnsEnded));
  event("voxbrick_sessions_accepted_total", "Connections whose Hello made them a session.",
        ServerEvent::SessionAccepted);
  m.family("voxbrick_refusals_total", Type::Counter,
           "Connections, requests and frames turned away, by reason (sessions, address, pending_evicted, output, "
           "busy, quota, stopping, forbidden).");
  for (const auto& entry : kRefusalNames) m.sample(double(refusals(entry.value)), {{"reason", entry.name}});
  event("voxbrick_timeouts_total", "Sessions closed for a deadline: idle, a message not complete in time, no Hello.",
        ServerEvent::Timeout);
  event("voxbrick_slow_clients_dropped_total", "Sessions closed because they did not read their replies.",
        ServerEvent::SlowClientDropped);
  event("voxbrick_reading_paused_total", "Times a session was not read because its replies waited unread.",
        ServerEvent::ReadingPaused);
  event("voxbrick_uploads_total", "Volumes clients sent that became datasets.", ServerEvent::Uploaded);
  event("voxbrick_uploads_refused_total",
        "Uploads refused, abandoned for a bad chunk, or whose prep failed (not those whose session ended).",
        ServerEvent::UploadRefused);

  // Messages and renders.
  event("voxbrick_messages_total", "Protocol messages read, decodable or not.", ServerEvent::Message);
  event("voxbrick_protocol_errors_total", "Protocol headers and bodies that did not decode.",
        ServerEvent::ProtocolError);
  event("voxbrick_render_requests_total", "Render requests received, accepted or not.", ServerEvent::RenderRequest);
  m.family("voxbrick_render_jobs_total", Type::Counter,
           "Render requests accepted for rendering (handed to the render queue), by class.");
  for (const FrameClass c : kAllFrameClasses) m.sample(double(mAccepted[size_t(c)].load()), byClass(c));
  const auto byClassAndEncoding = [&](std::string_view name, std::string_view help,
                                      const std::array<std::array<Counter, kFrameEncodings>, kFrameClasses>& counts) {
    m.family(name, Type::Counter, help);
    for (const FrameClass c : kAllFrameClasses)
      for (size_t e = 0; e < kFrameEncodings; ++e)
        m.sample(double(counts[size_t(c)][e].load()),
                 {{"class", common::nameOf(c)}, {"encoding", proto::encodingName(proto::Encoding(e))}});
  };
  byClassAndEncoding("voxbrick_frames_total",
                     "Frames answering a Render, by class and encoding (the exact frame after a provisional one is "
                     "counted in voxbrick_renders_refined_total).",
                     mFrames);
  m.family("voxbrick_frame_latency_seconds", Type::Histogram,
           "Seconds from a Render's arrival to its Frame being handed to the session, by class.");
  for (const FrameClass c : kAllFrameClasses) m.histogram(mLatencyByClass[size_t(c)].counts(), byClass(c));
  byClassAndEncoding("voxbrick_frame_bytes_total",
                     "Bytes of the Frame messages counted in voxbrick_frames_total, by class and encoding.",
                     mFrameBytes);
  m.family("voxbrick_video_encode_seconds", Type::Histogram,
           "Seconds to encode a video frame (a provisional frame of a session's vp8 or vp9 stream), by codec.");
  m.histogram(mVideoEncode[0].counts(), {{"codec", "vp8"}});
  m.histogram(mVideoEncode[1].counts(), {{"codec", "vp9"}});
  m.family("voxbrick_video_key_frames_total", Type::Counter,
           "Key frames of video streams, by reason: start, codec, size, dataset, asked (the client), recovery (after "
           "a failed or undelivered frame), memory (the stream's encoder had been freed for another's, or could not "
           "be made for want of room), encoder (the encoder's own).");
  for (size_t i = 0; i < kVideoKeyReasons.size(); ++i)
    m.sample(double(mVideoKeyFrames[i].load()), {{"reason", std::string(kVideoKeyReasons[i])}});
  m.family("voxbrick_video_scaled_frames_total", Type::Counter,
           "Video frames sent smaller than their scene, by reason: link (its bitrate is too low for the full size), "
           "encoders (the crowd leaves its frames less encoder time than the full size takes), memory (its encoder "
           "would hold more than a quarter of memory.video_mb).");
  for (const auto& [why, name] : kVideoScaledForNames)
    if (why != VideoScaledFor::None) m.sample(double(mVideoScaled[size_t(why)].load()), {{"reason", name}});
  one("voxbrick_video_encoders", Type::Gauge, "Video encoders the sessions' streams hold.",
      double(gauges.video.encoders));
  one("voxbrick_video_memory_bytes", Type::Gauge,
      "Bytes the sessions' video encoders hold, as estimated for each when it was made (memory.video_mb counts them).",
      double(gauges.video.bytes));
  one("voxbrick_video_memory_peak_bytes", Type::Gauge,
      "The most bytes the video encoders held together since the server started.", double(gauges.video.peakBytes));
  one("voxbrick_video_memory_limit_bytes", Type::Gauge, "The video encoders' budget, memory.video_mb.",
      double(gauges.video.limitBytes));
  one("voxbrick_video_encoders_freed_total", Type::Counter,
      "Encoders of resting streams freed to make room for another stream's.", double(gauges.video.freed));
  one("voxbrick_video_jpeg_frames_total", Type::Counter,
      "Moving frames of video streams sent as JPEG: no encoder could be made within memory.video_mb.",
      double(gauges.video.jpegFrames));
  one("voxbrick_bytes_written_total", Type::Counter,
      "Bytes of protocol messages written to clients, every message and transport.", double(mBytesOut.load()));
  event("voxbrick_render_errors_total", "Renders answered with an Error instead of a Frame.", ServerEvent::RenderError);
  event("voxbrick_renders_superseded_total", "Renders replaced by a newer one of their session (latest wins).",
        ServerEvent::Superseded);
  event("voxbrick_renders_refined_total", "Exact frames sent after a provisional one.", ServerEvent::Refined);
  one("voxbrick_renders_cancelled_total", Type::Counter,
      "Frames given up part way: their session had gone, or a newer Render overtook a refinement.",
      double(gauges.rendersCancelled));
  one("voxbrick_frames_shared_total", Type::Counter,
      "Renders delivered to a further session that asked for the same frame.", double(mFramesShared.load()));
  m.family("voxbrick_queue_depth", Type::Gauge, "Render jobs waiting for a render thread, by class.");
  for (const FrameClass c : kAllFrameClasses) m.sample(double(gauges.queuedByClass[size_t(c)]), byClass(c));
  m.family("voxbrick_encode_queue_depth", Type::Gauge,
           "Frames drawn and waiting for an encoder thread (video frames, still frames encoded aside), by class.");
  for (const FrameClass c : kAllFrameClasses) m.sample(double(gauges.encodesByClass[size_t(c)]), byClass(c));
  one("voxbrick_queued_sessions", Type::Gauge, "Sessions with a render job waiting.", double(gauges.queuedSessions));
  const auto perThread = [&m](std::string_view name, std::string_view help, const std::vector<double>& ms) {
    m.family(name, Type::Counter, help);
    for (size_t t = 0; t < ms.size(); ++t) m.sample(ms[t] / 1000, {{"thread", std::to_string(t)}});
  };
  perThread("voxbrick_render_thread_busy_seconds_total",
            "Seconds each render thread has spent drawing and encoding frames.", gauges.deviceBusyMs);
  perThread("voxbrick_render_thread_wait_seconds_total",
            "Seconds each render thread has spent asking the scheduler for its next job (waiting for work, or for "
            "the scheduler's lock).",
            gauges.deviceWaitMs);

  // Datasets' host caches.
  struct CacheFigure {
    const char* name;
    Type type;
    const char* help;
    double (*value)(const store::CacheStats&);
  };
  const CacheFigure cacheFigures[] = {
      {"voxbrick_cache_hits_total", Type::Counter, "Host cache lookups that found the brick, by dataset.",
       [](const store::CacheStats& c) { return double(c.hits); }},
      {"voxbrick_cache_misses_total", Type::Counter, "Host cache lookups that had to read the brick, by dataset.",
       [](const store::CacheStats& c) { return double(c.misses); }},
      {"voxbrick_cache_evictions_total", Type::Counter, "Bricks evicted from the host cache, by dataset.",
       [](const store::CacheStats& c) { return double(c.evictions); }},
      {"voxbrick_cache_resident_bytes", Type::Gauge, "Bytes of decoded bricks in the host cache, by dataset.",
       [](const store::CacheStats& c) { return double(c.residentBytes); }},
      {"voxbrick_cache_budget_bytes", Type::Gauge, "The host cache's budget, by dataset (its share of the server's).",
       [](const store::CacheStats& c) { return double(c.budgetBytes); }},
  };
  std::vector<store::CacheStats> caches;
  for (const auto& dataset : gauges.datasets) caches.push_back(dataset->cacheStats());
  for (const CacheFigure& figure : cacheFigures) {
    m.family(figure.name, figure.type, figure.help);
    for (size_t i = 0; i < caches.size(); ++i)
      m.sample(figure.value(caches[i]), {{"dataset", gauges.datasets[i]->name()}});
  }
  m.family("voxbrick_dataset_quarantined", Type::Gauge,
           "1 for an open dataset quarantined after a damaged brick (until it is replaced on disk), else 0.");
  for (const auto& dataset : gauges.datasets) m.sample(dataset->quarantined() ? 1 : 0, {{"dataset", dataset->name()}});

  // Memory and output.
  one("voxbrick_gpu_atlas_bytes", Type::Gauge, "Bytes of the render threads' brick atlases.", double(gauges.gpu.bytes));
  one("voxbrick_gpu_budget_bytes", Type::Gauge, "The server's GPU budget for brick atlases (memory.gpu_budget_mb).",
      double(gauges.gpuBudgetBytes));
  one("voxbrick_gpu_renderers_released_total", Type::Counter,
      "Renderers (atlases) released to make room for another dataset's.", double(gauges.gpu.renderersReleased));
  one("voxbrick_resident_memory_bytes", Type::Gauge, "Resident memory of the server process (host).", double(rss));
  one("voxbrick_resident_memory_peak_bytes", Type::Gauge, "Peak resident memory of the server process (host).",
      double(peak));
  one("voxbrick_output_queued_bytes", Type::Gauge, "Bytes of replies queued for all sessions, not yet written.",
      double(gauges.outputQueuedBytes));
  one("voxbrick_output_limit_bytes", Type::Gauge,
      "The limit on replies queued for all sessions (limits.max_total_output_bytes).", double(gauges.outputLimitBytes));
  return m.text();
}

}  // namespace voxbrick::server
