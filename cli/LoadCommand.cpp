// `voxbrick load HOST:PORT --clients N --duration S`: concurrent well-behaved clients, optionally mixed with faulty
// ones, reporting throughput, latency percentiles and errors.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <thread>

#include <nlohmann/json.hpp>

#include "cli/Commands.h"
#include "cli/LoadFaults.h"
#include "client/Client.h"
#include "render/core/Scene.h"
#include "render/engine/Datasets.h"

namespace voxbrick::cli {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

struct Tally {
  std::mutex mutex;
  std::vector<double> latencies;
  std::vector<double> renderMs;      ///< the renderer's own frame time (frame statistics), well-behaved clients
  std::vector<double> renderMsWarm;  ///< the same without each client's first frame (which pages its bricks in)
  int64_t frames = 0, errors = 0, superseded = 0, payloadBytes = 0;
  int64_t provisional = 0;     ///< dragging clients: first replies that were provisional frames
  int64_t exactFollowUps = 0;  ///< dragging clients: exact frames of requests a provisional frame already answered
  std::vector<std::string> errorSamples;
  std::map<std::string, int64_t> faultsDone, faultsUnexpected;

  void error(const std::string& what) {
    std::lock_guard lock(mutex);
    ++errors;
    if (errorSamples.size() < 10) errorSamples.push_back(what);
  }
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(p * double(v.size())))];
}

/// The slowest frame's rate over the fastest's (the fastest frame's time over the slowest's), in (0, 1]; 0 when
/// there are no frames.
double frameRateRatio(const std::vector<double>& ms) {
  if (ms.empty()) return 0;
  const auto [lo, hi] = std::minmax_element(ms.begin(), ms.end());
  return *hi > 0 ? *lo / *hi : 0;
}

/// A well-behaved client: one request at a time until the deadline, every latency recorded.
void goodClient(const LoadArgs& a, const std::string& host, int port, int width, int height, int index,
                Clock::time_point deadline, Tally& tally) {
  try {
    client::Client c(host, port, std::chrono::seconds(60));
    c.hello("voxbrick-load");
    c.openDataset(a.dataset);
    for (int n = 0; Clock::now() < deadline; ++n) {
      const auto start = Clock::now();
      const proto::Frame frame =
          c.render(sceneJson(a, width, height, 10.0 * index + 7.0 * n), client::encodingNamed(a.encoding));
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
      const json stats = json::parse(frame.statsJson);
      std::lock_guard lock(tally.mutex);
      tally.latencies.push_back(ms);
      tally.renderMs.push_back(stats["ms"]["total"].get<double>());
      if (n > 0) tally.renderMsWarm.push_back(tally.renderMs.back());
      ++tally.frames;
      tally.payloadBytes += int64_t(frame.payload.size());
    }
    c.goodbye();
  } catch (const std::exception& e) {
    tally.error(e.what());
  }
}

/// The scene of a dragging client: the load's scene and, with --interactive, the keys of a camera in motion.
std::string dragSceneJson(const LoadArgs& a, int width, int height, double azimuth) {
  json scene = json::parse(sceneJson(a, width, height, azimuth));
  if (a.interactiveMs > 0) scene["interactive"] = true, scene["time_budget_ms"] = a.interactiveMs;
  if (!a.provisionalEncoding.empty()) scene["provisional_encoding"] = a.provisionalEncoding;
  return scene.dump();
}

/// Counts one reply of a dragging client. `sentAt`: when its request was sent, or nullopt when the request was
/// already answered (the exact frame that follows a provisional one).
void tallyDragReply(const proto::Message& m, std::optional<Clock::time_point> sentAt, Tally& tally) {
  std::lock_guard lock(tally.mutex);
  const auto* frame = std::get_if<proto::Frame>(&m);
  const auto* error = std::get_if<proto::Error>(&m);
  if (error && error->code == proto::ErrorCode::Superseded) {
    ++tally.superseded;
  } else if (frame && !sentAt) {
    ++tally.exactFollowUps;
  } else if (frame) {
    tally.latencies.push_back(std::chrono::duration<double, std::milli>(Clock::now() - *sentAt).count());
    ++tally.frames;
    tally.payloadBytes += int64_t(frame->payload.size());
    if (json::parse(frame->statsJson).value("provisional", false)) ++tally.provisional;
  } else if (!std::holds_alternative<proto::DatasetList>(m)) {  // a DatasetList answers the closing request
    ++tally.errors;
  }
}

/// A client dragging the camera: sends a new camera `hz` times a second without waiting, and reads frames as they
/// come. Each frame's latency is the age of the camera it shows (an interactive request's first frame, provisional
/// or not; the exact frame that may follow is counted apart). Superseded requests are counted, not errors.
void dragClient(const LoadArgs& a, const std::string& host, int port, int width, int height, int index,
                Clock::time_point deadline, Tally& tally) {
  try {
    client::Client c(host, port, std::chrono::seconds(120));
    c.hello("voxbrick-load-drag");
    c.openDataset(a.dataset);
    std::mutex mutex;
    std::map<uint32_t, Clock::time_point> sent;
    std::atomic<bool> sending{true};
    std::thread reader([&] {
      try {
        for (;;) {
          {
            std::lock_guard lock(mutex);
            if (!sending && sent.empty()) return;
          }
          auto [id, m] = c.receive();
          std::optional<Clock::time_point> sentAt;
          {
            std::lock_guard lock(mutex);
            if (const auto it = sent.find(id); it != sent.end()) sentAt = it->second, sent.erase(it);
          }
          tallyDragReply(m, sentAt, tally);
        }
      } catch (const std::exception& e) {
        tally.error(e.what());
      }
    });
    const auto period = std::chrono::duration<double>(1.0 / a.dragHz);
    auto next = Clock::now();
    for (int n = 0; Clock::now() < deadline; ++n) {
      {
        std::lock_guard lock(mutex);
        const uint32_t id = c.send(proto::RenderRequest{client::encodingNamed(a.encoding),
                                                        dragSceneJson(a, width, height, 10.0 * index + 2.0 * n)});
        sent[id] = Clock::now();
      }
      next += std::chrono::duration_cast<Clock::duration>(period);
      std::this_thread::sleep_until(next);
    }
    {
      // A last cheap request: its reply wakes the reader even when every frame has already arrived.
      std::lock_guard lock(mutex);
      sending = false;
      sent[c.send(proto::ListDatasets{})] = Clock::now();
    }
    reader.join();
    c.goodbye();
  } catch (const std::exception& e) {
    tally.error(e.what());
  }
}

ServerDeadlines serverDeadlines(const std::string& host, int port) {
  ServerDeadlines d;
  try {
    client::Client c(host, port, std::chrono::seconds(30));
    c.hello("voxbrick-load-limits");
    const json limits = json::parse(c.stats()).value("limits", json::object());
    d.helloS = limits.value("hello_timeout_s", d.helloS);
    d.readS = limits.value("read_timeout_s", d.readS);
    c.goodbye();
  } catch (const std::exception&) {  // the faults then wait for the defaults; a bad server shows in their replies
  }
  return d;
}

void faultClient(const LoadArgs& a, const ServerDeadlines& deadlines, const std::string& host, int port,
                 const std::vector<const Fault*>& faults, int index, Clock::time_point deadline, Tally& tally) {
  std::mt19937 rng(unsigned(1234 + index));
  FaultRun run{a, deadlines, rng};
  for (size_t n = size_t(index); Clock::now() < deadline; ++n) {
    const Fault& f = *faults[n % faults.size()];
    bool ok = false;
    try {
      ok = runFault(f, host, port, run);
    } catch (const std::exception&) {
      ok = false;
    }
    {
      std::lock_guard lock(tally.mutex);
      ++tally.faultsDone[f.name];
      if (!ok) ++tally.faultsUnexpected[f.name];
    }
    // Faults are mixed in, not a flood: each faulty client misbehaves about twenty times a second at most.
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

/// Idle sessions: connected and greeted, then silent for the whole run.
std::vector<std::unique_ptr<client::Client>> openIdleSessions(const std::string& host, int port, int count) {
  std::vector<std::unique_ptr<client::Client>> idle;
  for (int i = 0; i < count; ++i) {
    idle.push_back(std::make_unique<client::Client>(host, port, std::chrono::seconds(10)));
    idle.back()->hello("voxbrick-load-idle");
  }
  return idle;
}

/// The server's statistics after the run; an error in the tally (and an empty object) if it does not answer.
json serverStatsAfter(const std::string& host, int port, Tally& tally) {
  try {
    client::Client c(host, port, std::chrono::seconds(30));
    c.hello("voxbrick-load-stats");
    json server = json::parse(c.stats());
    c.goodbye();
    return server;
  } catch (const std::exception& e) {
    tally.error(std::string("server statistics after the run: ") + e.what());
  }
  return json();
}

/// Per fault, how often it ran and how many replies were not as documented; `unexpected` gets the total of those.
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

json loadReport(const LoadArgs& a, const Tally& tally, double seconds, int width, int height, const json& faults,
                const json& server) {
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
      {"drag_hz", a.dragHz},
      {"error_samples", tally.errorSamples},
      {"latency_ms",
       {{"p50", percentile(tally.latencies, 0.5)},
        {"p95", percentile(tally.latencies, 0.95)},
        {"p99", percentile(tally.latencies, 0.99)},
        {"max", percentile(tally.latencies, 1.0)}}},
      {"render_ms_p50", percentile(tally.renderMs, 0.5)},
      // Over the orbit the clients turn through (warm frames): the slowest frame against the fastest.
      {"warm_render_ms", {{"min", percentile(tally.renderMsWarm, 0.0)}, {"max", percentile(tally.renderMsWarm, 1.0)}}},
      {"frame_rate_min_over_max", frameRateRatio(tally.renderMsWarm)},
      {"faults", faults},
      {"server", server}};
}

void printSummary(const LoadArgs& a, const Tally& tally, double seconds, int64_t unexpected, const json& server) {
  std::printf(
      "load: %d clients (+%d faulty, %d idle) for %.1f s: %lld frames, %.1f frames/s, latency p50 %.1f "
      "p95 %.1f p99 %.1f max %.1f ms, %lld superseded, %lld errors, %lld unexpected fault replies",
      a.clients, a.faultClients, a.idleSessions, seconds, (long long)tally.frames, double(tally.frames) / seconds,
      percentile(tally.latencies, 0.5), percentile(tally.latencies, 0.95), percentile(tally.latencies, 0.99),
      percentile(tally.latencies, 1.0), (long long)tally.superseded, (long long)tally.errors, (long long)unexpected);
  if (!tally.renderMsWarm.empty())
    std::printf(", warm frames %.1f-%.1f ms (min/max frame rate 1:%.2f)", percentile(tally.renderMsWarm, 0.0),
                percentile(tally.renderMsWarm, 1.0), 1 / frameRateRatio(tally.renderMsWarm));
  if (server.contains("memory"))
    std::printf(", server RSS %.0f MB (peak %.0f MB)", double(server["memory"]["rss_bytes"]) / 1e6,
                double(server["memory"]["peak_rss_bytes"]) / 1e6);
  std::printf("\n");
  for (const std::string& e : tally.errorSamples) std::printf("  error: %s\n", e.c_str());
}

void runLoad(const LoadArgs& a) {
  const auto [host, port] = client::parseAddress(a.address);
  int width = 0, height = 0;
  parseSize(a.size, "--size", width, height);
  if (width < 1 || height < 1) throw std::invalid_argument("--size '" + a.size + "': sides must be positive");
  const std::vector<const Fault*> faults = faultsToRun(a);
  std::vector<std::unique_ptr<client::Client>> idle = openIdleSessions(host, port, a.idleSessions);

  const ServerDeadlines deadlines = a.faultClients > 0 ? serverDeadlines(host, port) : ServerDeadlines{};
  Tally tally;
  const auto start = Clock::now();
  const auto deadline = start + std::chrono::milliseconds(int64_t(a.duration * 1000));
  std::vector<std::thread> threads;
  for (int i = 0; i < a.clients; ++i)
    threads.emplace_back(a.dragHz > 0 ? dragClient : goodClient, std::cref(a), host, port, width, height, i, deadline,
                         std::ref(tally));
  for (int i = 0; i < a.faultClients; ++i)
    threads.emplace_back(faultClient, std::cref(a), std::cref(deadlines), host, port, std::cref(faults), i, deadline,
                         std::ref(tally));
  for (std::thread& t : threads) t.join();
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();

  const json server = serverStatsAfter(host, port, tally);
  idle.clear();
  int64_t unexpected = 0;
  const json faultsDone = faultCounts(tally, unexpected);
  printSummary(a, tally, seconds, unexpected, server);
  if (!a.jsonPath.empty())
    writeText(a.jsonPath, loadReport(a, tally, seconds, width, height, faultsDone, server).dump(2) + "\n");
  if (a.requireClean && (tally.errors > 0 || unexpected > 0 || tally.frames == 0))
    throw std::runtime_error("the run was not clean: " + std::to_string(tally.errors) + " errors, " +
                             std::to_string(unexpected) + " unexpected fault replies, " + std::to_string(tally.frames) +
                             " frames");
}

}  // namespace

void addLoadCommand(CLI::App& app) {
  auto a = std::make_shared<LoadArgs>();
  CLI::App* cmd = app.add_subcommand("load", "Load-test a running server with concurrent clients and faults");
  cmd->add_option("address", a->address, "HOST:PORT of the server")->required();
  cmd->add_option("--dataset", a->dataset, "dataset the clients render")->required();
  cmd->add_option("--clients", a->clients, "well-behaved clients")->capture_default_str()->check(between(0, 4096));
  cmd->add_option("--duration", a->duration, "seconds")->capture_default_str()->check(between(0.1, 86400.0));
  cmd->add_option("--size", a->size, "frame size WIDTHxHEIGHT")->capture_default_str();
  cmd->add_option("--tf", a->tf, "transfer function preset")->capture_default_str();
  cmd->add_option("--step", a->step, "sampling step in voxels (the scene's step)")
      ->capture_default_str()
      ->check(between(0.001, 64, "voxels"));
  cmd->add_option("--encoding", a->encoding,
                  "how the clients' frames travel: raw, png, zstd or jpeg (lossy; protocol version 2)")
      ->capture_default_str()
      ->check(CLI::IsMember(proto::encodingShortNames()));
  cmd->add_option("--fault-clients", a->faultClients, "clients that misbehave in turn")
      ->capture_default_str()
      ->check(between(0, 4096));
  cmd->add_option("--faults", a->faults, "comma list of what faulty clients do (default all): " + faultUsage())
      ->delimiter(',')
      ->check(CLI::IsMember(faultNames()));
  cmd->add_option("--corrupt-dataset", a->corruptDataset,
                  "a damaged dataset of the server for the 'corrupt' fault (its renders must be answered Internal, "
                  "quarantined)");
  cmd->add_option("--idle-sessions", a->idleSessions, "sessions opened and left silent")
      ->capture_default_str()
      ->check(between(0, 100000));
  CLI::Option* drag =
      cmd->add_option(
             "--drag", a->dragHz,
             "clients send a new camera this many times a second without waiting (a camera drag); latency "
             "is then the age of the camera each frame shows (0: each client waits for its frame before the next)")
          ->capture_default_str()
          ->check(between(0.0, 1000.0));
  cmd->add_option("--interactive", a->interactiveMs,
                  "with --drag: Renders carry \"interactive\": true with this time budget in ms (a provisional frame "
                  "within it, the exact frame once the camera rests)")
      ->check(between(render::Scene::kMinTimeBudgetMs, render::Scene::kMaxTimeBudgetMs, "ms"))
      ->needs(drag);
  cmd->add_option("--provisional-encoding", a->provisionalEncoding,
                  "with --drag: how provisional frames travel (provisional_encoding): raw, png, zstd or jpeg")
      ->check(CLI::IsMember(proto::encodingShortNames()))
      ->needs(drag);
  cmd->add_option("--json", a->jsonPath, "write the report as JSON");
  cmd->add_flag("--require-clean", a->requireClean,
                "exit non-zero unless every good request succeeded and every fault got its documented reply");
  cmd->callback([a] { runLoad(*a); });
}

}  // namespace voxbrick::cli
