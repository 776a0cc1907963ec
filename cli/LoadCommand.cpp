// `voxbrick load HOST:PORT --clients N --duration S`: concurrent well-behaved clients, optionally mixed with faulty
// ones, reporting throughput, latency percentiles and errors.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "cli/Commands.h"
#include "cli/LoadFaults.h"
#include "cli/LoadTally.h"
#include "client/Client.h"
#include "image/Video.h"
#include "render/core/Scene.h"
#include "render/engine/Datasets.h"

namespace voxbrick::cli {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

/// The longest a client waits out one Busy reply's retry hint.
constexpr std::chrono::milliseconds kMaxBusyWait{5000};

/// How long to wait before the next request after an Error `code` with `message` (client::retryAfter), at most
/// kMaxBusyWait; none for an error that is not Busy.
std::optional<std::chrono::milliseconds> busyWait(proto::ErrorCode code, const std::string& message) {
  const auto wait = client::retryAfter(code, message);
  return wait ? std::optional(std::min(*wait, kMaxBusyWait)) : std::nullopt;
}

/// Whether an Error refuses the scene key batch: a server older than the key names it unknown (InvalidScene).
bool refusesBatch(proto::ErrorCode code, const std::string& message) {
  return code == proto::ErrorCode::InvalidScene && message.find("'batch'") != std::string::npos;
}

/// Sleeps `wait`, or until `deadline` if that comes first.
void waitOut(std::chrono::milliseconds wait, Clock::time_point deadline) {
  std::this_thread::sleep_until(std::min(Clock::now() + wait, deadline));
}

/// The scene of a well-behaved client: the load's scene, with `"batch": true` while `batch`.
std::string clientSceneJson(const LoadArgs& a, bool batch, int width, int height, double azimuth) {
  if (!batch) return sceneJson(a, width, height, azimuth);
  json scene = json::parse(sceneJson(a, width, height, azimuth));
  scene["batch"] = true;
  return scene.dump();
}

/// A connection of one of the load's clients to the server, with TLS as the options say.
std::unique_ptr<client::Client> connectTo(const LoadArgs& a, const std::string& host, int port,
                                          std::chrono::milliseconds timeout) {
  return std::make_unique<client::Client>(host, port, timeout, tlsOptionsOf(a.connect));
}

/// Hello, then the access token if the options give one.
proto::Capabilities greet(const LoadArgs& a, client::Client& c, const std::string& name) {
  proto::Capabilities caps = c.hello(name);
  if (const std::string token = accessTokenOf(a.connect); !token.empty()) c.authenticate(token);
  return caps;
}

/// A well-behaved client's session: connected, greeted (the highest protocol version both sides speak) and with
/// --dataset open. A session refused Busy (in place of Capabilities; the server closes it) is counted, waited out
/// and asked again; none if `deadline` passes first.
std::unique_ptr<client::Client> openSession(const LoadArgs& a, const std::string& host, int port, const char* name,
                                            int index, Clock::time_point deadline, Tally& tally) {
  while (Clock::now() < deadline) {
    auto c = connectTo(a, host, port, std::chrono::seconds(120));
    try {
      const proto::Capabilities caps = greet(a, *c, name);
      c->openDataset(a.dataset);
      std::lock_guard lock(tally.mutex);
      if (tally.protocolVersion == 0 || caps.version < tally.protocolVersion) tally.protocolVersion = caps.version;
      return c;
    } catch (const client::ServerError& e) {
      const auto wait = busyWait(e.code(), e.what());
      if (!wait) throw;
      {
        std::lock_guard lock(tally.mutex);
        tally.countBusy(index);
      }
      waitOut(*wait, deadline);
    }
  }
  return nullptr;
}

/// The time budget an interactive frame was drawn to (its statistics' "interactive"), if it says one.
std::optional<double> frameBudgetMs(const json& stats) {
  const json interactive = stats.value("interactive", json());
  if (!interactive.is_object() || !interactive.contains("budget_ms")) return std::nullopt;
  return interactive["budget_ms"].get<double>();
}

/// A well-behaved client: one request at a time until the deadline, every latency recorded. A Render answered Busy
/// is counted and its retry hint waited out before the next request.
void goodClient(const LoadArgs& a, const std::string& host, int port, int width, int height, int index,
                Clock::time_point deadline, Tally& tally) {
  try {
    const std::unique_ptr<client::Client> c = openSession(a, host, port, "voxbrick-load", index, deadline, tally);
    if (!c) return;
    bool batch = a.batch;
    for (int n = 0; Clock::now() < deadline; ++n) {
      const auto start = Clock::now();
      proto::Frame frame;
      try {
        frame = c->render(clientSceneJson(a, batch, width, height, 10.0 * index + 7.0 * n),
                          client::encodingNamed(a.encoding));
      } catch (const client::ServerError& e) {
        if (const auto wait = busyWait(e.code(), e.what())) {
          {
            std::lock_guard lock(tally.mutex);
            tally.countBusy(index);
          }
          waitOut(*wait, deadline);
          continue;
        }
        if (!batch || !refusesBatch(e.code(), e.what())) throw;
        batch = false;  // a server older than the key: the same frames without it
        std::lock_guard lock(tally.mutex);
        ++tally.batchRefused;
        continue;
      }
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
      const json stats = json::parse(frame.statsJson);
      std::lock_guard lock(tally.mutex);
      tally.countFrame(index, ms);
      tally.renderMs.push_back(stats["ms"]["total"].get<double>());
      if (n > 0) tally.renderMsWarm.push_back(tally.renderMs.back());
      if (const auto budget = frameBudgetMs(stats)) tally.budgetMs.push_back(*budget);
      tally.payloadBytes += int64_t(frame.payload.size());
    }
    c->goodbye();
  } catch (const std::exception& e) {
    tally.error(e.what(), index);
  }
}

/// The scene of a dragging client: the load's scene and, with --interactive, the keys of a camera in motion.
std::string dragSceneJson(const LoadArgs& a, bool batch, int width, int height, double azimuth) {
  json scene = json::parse(clientSceneJson(a, batch, width, height, azimuth));
  if (a.interactiveMs > 0) scene["interactive"] = true, scene["time_budget_ms"] = a.interactiveMs;
  if (!a.provisionalEncoding.empty()) scene["provisional_encoding"] = a.provisionalEncoding;
  if (a.vp9FullChroma) scene["accepts_vp9_444"] = true;
  return scene.dump();
}

/// Counts one reply of dragging client `index`. `sentAt`: when its request was sent, or nullopt when the request was
/// already answered (the exact frame that follows a provisional one). Returns how long to hold the next request
/// when the reply was Busy. A refusal of the scene key batch clears `batch` (the later Renders go without it).
std::optional<std::chrono::milliseconds> tallyDragReply(const proto::Message& m,
                                                        std::optional<Clock::time_point> sentAt, int index, bool& batch,
                                                        Tally& tally) {
  std::lock_guard lock(tally.mutex);
  ClientFigures& mine = tally.clients[size_t(index)];
  const auto* frame = std::get_if<proto::Frame>(&m);
  const auto* error = std::get_if<proto::Error>(&m);
  if (error && error->code == proto::ErrorCode::Superseded) {
    ++tally.superseded;
  } else if (error) {
    if (const auto wait = busyWait(error->code, error->message)) {
      tally.countBusy(index);
      return wait;
    }
    if (batch && refusesBatch(error->code, error->message)) {
      batch = false;
      ++tally.batchRefused;
      return std::nullopt;
    }
    ++tally.errors, ++mine.errors;
    if (tally.errorSamples.size() < 10)
      tally.errorSamples.push_back(std::string(proto::errorCodeName(error->code)) + ": " + error->message);
  } else if (frame && !sentAt) {
    ++tally.exactFollowUps;
  } else if (frame) {
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - *sentAt).count();
    tally.countFrame(index, ms);
    tally.payloadBytes += int64_t(frame->payload.size());
    const json stats = json::parse(frame->statsJson);
    if (stats.value("provisional", false)) ++tally.provisional;
    if (stats.contains("encode_ms")) tally.encodeMs.push_back(stats["encode_ms"].get<double>());
    if (stats.contains("ms")) tally.renderMs.push_back(stats["ms"].value("total", 0.0));
    if (const auto budget = frameBudgetMs(stats)) tally.budgetMs.push_back(*budget);
    if (stats.contains("interactive") && stats["interactive"].is_object()) {
      const json& interactive = stats["interactive"];
      tally.drawnScale.push_back(interactive.value("scale", 1.0));
      if (interactive.value("predicted_ms", 0.0) > 0) {
        tally.predictedMs.push_back(interactive["predicted_ms"].get<double>());
        tally.actualMs.push_back(interactive.value("actual_ms", 0.0));
      }
    }
    if (stats.contains("video") && stats["video"].is_object()) {
      tally.sentScale.push_back(stats["video"].value("scale", 1.0));
    } else if (stats.contains("interactive") && stats["interactive"].is_object()) {
      // A still-encoded moving frame: sent at its drawn size (protocol version 8) or at the scene's.
      const double drawnWidth = stats["interactive"].value("width", 0.0), scale = stats["interactive"].value("scale", 0.0);
      if (drawnWidth > 0 && scale > 0) tally.sentScale.push_back(double(frame->width) / std::round(drawnWidth / scale));
    }
  } else if (!std::holds_alternative<proto::DatasetList>(m)) {  // a DatasetList answers the closing request
    ++tally.errors, ++mine.errors;
  }
  return std::nullopt;
}

/// Decodes a video frame of dragging client `index` in its stream, timing it. A frame that does not decode is an error
/// of the run, and sets `wantKey` (the client's next Render asks for a key frame).
void decodeVideo(image::FrameDecoder& decoder, const proto::Frame& frame, int index, bool& wantKey, Tally& tally) {
  const auto start = Clock::now();
  try {
    decoder.decode(frame);
  } catch (const std::exception& e) {
    wantKey = true;
    tally.error(std::string("video frame: ") + e.what(), index);
    return;
  }
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  const json stats = json::parse(frame.statsJson, nullptr, false);
  std::lock_guard lock(tally.mutex);
  tally.decodeMs.push_back(ms);
  ++tally.videoFrames;
  if (stats.is_object() && stats.contains("video") && stats["video"].is_object()) {
    if (stats["video"].value("key", false)) ++tally.keyFrames;
    if (stats["video"].value("chroma", "") == "4:4:4") ++tally.fullChromaFrames;
  }
}

/// --drag-cycle's drags and rests of one client: DRAG seconds dragging, then REST resting, over and over from the
/// run's start, shifted by a phase drawn for the client (seeded by its index: the same in every run), so that a crowd's
/// drags begin and end at different times, as people's do. Empty: no cycle (false).
class DragCycle {
 public:
  DragCycle(const std::vector<double>& dragRest, Clock::time_point start, int index) : mStart(start) {
    if (dragRest.size() != 2) return;
    mDragS = dragRest[0], mPeriodS = dragRest[0] + dragRest[1];
    std::mt19937 rng(unsigned(4321 + index));
    mPhaseS = std::uniform_real_distribution<double>(0, mPeriodS)(rng);
  }
  explicit operator bool() const { return mPeriodS > 0; }
  /// The cycle `t` is in (counted from the run's start), and whether it drags then.
  std::pair<int64_t, bool> at(Clock::time_point t) const {
    const double s = seconds(t), k = std::floor(s / mPeriodS);
    return {int64_t(k), s - k * mPeriodS < mDragS};
  }
  /// When the drag or rest under way at `t` ends.
  Clock::time_point nextChange(Clock::time_point t) const {
    const double s = seconds(t), into = s - std::floor(s / mPeriodS) * mPeriodS;
    const double left = into < mDragS ? mDragS - into : mPeriodS - into;
    return t + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(left));
  }

 private:
  double seconds(Clock::time_point t) const { return std::chrono::duration<double>(t - mStart).count() + mPhaseS; }
  Clock::time_point mStart;
  double mDragS = 0, mPeriodS = 0, mPhaseS = 0;
};

/// A client dragging the camera: sends a new camera `hz` times a second without waiting, and reads frames as they
/// come, both from one thread (the client is not thread-safe). Each frame's latency is the age of the camera it shows
/// (an interactive request's first frame, provisional or not; the exact frame that may follow is counted apart).
/// Superseded requests are counted, not errors; a Busy reply is counted and holds the next camera for its retry hint.
/// With --drag-cycle the client drags and rests in turn, from a phase of its own; each drag's wait for its first frame
/// is kept, and each drag ends as a viewer's release does: with a still Render of its last camera.
void dragClient(const LoadArgs& a, const std::string& host, int port, int width, int height, int index,
                Clock::time_point deadline, Tally& tally) {
  try {
    const std::unique_ptr<client::Client> session =
        openSession(a, host, port, "voxbrick-load-drag", index, deadline, tally);
    if (!session) return;
    client::Client& c = *session;
    std::map<uint32_t, Clock::time_point> sent;  // requests not yet answered, and when each was sent
    bool batch = a.batch;
    Clock::time_point hold;  // no request before this: a Busy reply's retry hint
    image::FrameDecoder decoder;
    bool wantKey = false;  // a video frame failed to decode: the next Render asks for a key frame
    DragCycle cycle(a.dragCycle, tally.started, index);
    std::optional<Clock::time_point> dragBegan;  // the drag under way's first camera, until its first frame comes
    std::set<uint32_t> releases;                 // the still Renders that ended its drags
    const auto readReply = [&] {
      auto [id, m] = c.receive();
      const auto* frame = std::get_if<proto::Frame>(&m);
      if (frame) {
        c.frameReceived(id, *frame);  // so the server paces this session to what arrives (version 4 on)
        if (image::isVideoEncoding(frame->encoding)) decodeVideo(decoder, *frame, index, wantKey, tally);
      }
      std::optional<Clock::time_point> sentAt;
      if (const auto it = sent.find(id); it != sent.end()) sentAt = it->second, sent.erase(it);
      if (releases.erase(id)) {  // a release's frame is no moving one: counted as an exact frame
        if (frame && sentAt) {
          std::lock_guard lock(tally.mutex);
          tally.clients[size_t(index)].releaseWaitsMs.push_back(
              std::chrono::duration<double, std::milli>(Clock::now() - *sentAt).count());
        }
        sentAt.reset();
      }
      if (frame && dragBegan && sentAt && *sentAt >= *dragBegan) {
        std::lock_guard lock(tally.mutex);
        ClientFigures& mine = tally.clients[size_t(index)];
        ++mine.dragsTaken;
        mine.dragWaitsMs.push_back(std::chrono::duration<double, std::milli>(Clock::now() - *dragBegan).count());
        dragBegan.reset();
      }
      if (const auto wait = tallyDragReply(m, sentAt, index, batch, tally)) hold = Clock::now() + *wait;
    };
    const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / a.dragHz));
    auto next = Clock::now();
    int64_t drag = -1;  // the cycle of the drag under way or last begun
    for (int n = 0;;) {
      const auto now = Clock::now();
      if (now >= deadline) break;
      if (cycle) {
        const auto [at, dragging] = cycle.at(now);
        if (dragging && at != drag) {  // a drag begins
          drag = at, dragBegan = now, next = now;
        } else if (!dragging && at == drag) {  // it ends: released as a viewer does, with a still Render
          if (dragBegan) {                     // without a frame
            std::lock_guard lock(tally.mutex);
            ++tally.clients[size_t(index)].dragsRefused;
          }
          dragBegan.reset();
          drag = -1;
          const uint32_t id =
              c.send(proto::RenderRequest{client::encodingNamed(a.encoding),
                                          clientSceneJson(a, batch, width, height, 10.0 * index + 2.0 * (n - 1))});
          sent[id] = now, releases.insert(id);
        }
        if (!dragging) {  // resting: the replies as they come until the next drag
          const auto until = std::min(cycle.nextChange(now), deadline);
          if (c.waitReadable(std::chrono::ceil<std::chrono::milliseconds>(until - now))) readReply();
          continue;
        }
      }
      if (now >= next && now >= hold) {
        std::string scene = dragSceneJson(a, batch, width, height, 10.0 * index + 2.0 * n++);
        if (wantKey) {
          json withKey = json::parse(scene);
          withKey["keyframe"] = true;
          scene = withKey.dump();
          wantKey = false;
        }
        sent[c.send(proto::RenderRequest{client::encodingNamed(a.encoding), scene})] = now;
        next = std::max(next + period, hold);
        continue;
      }
      // Until the next camera is due, the replies as they come.
      auto until = std::min(std::max(next, hold), deadline);
      if (cycle) until = std::min(until, cycle.nextChange(now));
      if (c.waitReadable(std::chrono::ceil<std::chrono::milliseconds>(until - now))) readReply();
    }
    // A last cheap request, so that the replies are read until every request has its first one.
    sent[c.send(proto::ListDatasets{})] = Clock::now();
    while (!sent.empty()) readReply();
    c.goodbye();
  } catch (const std::exception& e) {
    tally.error(e.what(), index);
  }
}

ServerDeadlines serverDeadlines(const LoadArgs& a, const std::string& host, int port) {
  ServerDeadlines d;
  try {
    const auto c = connectTo(a, host, port, std::chrono::seconds(30));
    greet(a, *c, "voxbrick-load-limits");
    const json limits = json::parse(c->stats()).value("limits", json::object());
    d.helloS = limits.value("hello_timeout_s", d.helloS);
    d.readS = limits.value("read_timeout_s", d.readS);
    c->goodbye();
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
std::vector<std::unique_ptr<client::Client>> openIdleSessions(const LoadArgs& a, const std::string& host, int port,
                                                              int count) {
  std::vector<std::unique_ptr<client::Client>> idle;
  for (int i = 0; i < count; ++i) {
    idle.push_back(connectTo(a, host, port, std::chrono::seconds(10)));
    greet(a, *idle.back(), "voxbrick-load-idle");
  }
  return idle;
}

/// The server's statistics: null if it does not answer, which after the run is an error in the tally (before it,
/// the run's own clients say whether the server answers).
json serverStats(const LoadArgs& a, const std::string& host, int port, Tally* tallyAfter) {
  try {
    const auto c = connectTo(a, host, port, std::chrono::seconds(30));
    greet(a, *c, "voxbrick-load-stats");
    json server = json::parse(c->stats());
    c->goodbye();
    return server;
  } catch (const std::exception& e) {
    if (tallyAfter) tallyAfter->error(std::string("server statistics after the run: ") + e.what());
  }
  return json();
}

/// The first scene the first well-behaved client sends (the report shows it).
json firstScene(const LoadArgs& a, int width, int height) {
  return json::parse(a.dragHz > 0 ? dragSceneJson(a, a.batch, width, height, 0)
                                  : clientSceneJson(a, a.batch, width, height, 0));
}

void runLoad(const LoadArgs& a) {
  const auto [host, port] = client::parseAddress(a.address);
  int width = 0, height = 0;
  parseSize(a.size, "--size", width, height);
  if (width < 1 || height < 1) throw std::invalid_argument("--size '" + a.size + "': sides must be positive");
  const std::vector<const Fault*> faults = faultsToRun(a);
  std::vector<std::unique_ptr<client::Client>> idle = openIdleSessions(a, host, port, a.idleSessions);

  const ServerDeadlines deadlines = a.faultClients > 0 ? serverDeadlines(a, host, port) : ServerDeadlines{};
  Tally tally(a.clients);
  // The server's counters as the run begins, so that a report can take the run's own share of them (render threads'
  // busy seconds, frames) from those after it.
  const json serverBefore = serverStats(a, host, port, nullptr);
  const auto start = Clock::now();
  tally.started = start;
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

  const json server = serverStats(a, host, port, &tally);
  idle.clear();
  int64_t unexpected = 0;
  const json faultsDone = faultCounts(tally, unexpected);
  printSummary(a, tally, seconds, unexpected, server);
  if (!a.jsonPath.empty()) {
    const json report =
        loadReport(a, tally, seconds, width, height, faultsDone, server, serverBefore, firstScene(a, width, height));
    writeText(a.jsonPath, report.dump(2) + "\n");
  }
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
                  "how the clients' frames travel: raw, png, zstd, jpeg (lossy; protocol version 2) or webp (lossless; "
                  "protocol version 7)")
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
                  "with --drag: how provisional frames travel (provisional_encoding): raw, png, zstd, jpeg, webp, or a "
                  "video stream, vp8 or vp9 (decoded by each client in order)")
      ->check(CLI::IsMember(proto::encodingShortNames()))
      ->needs(drag);
  cmd->add_flag("--vp9-444", a->vp9FullChroma,
                "with --provisional-encoding vp9: the stream in 4:4:4 (accepts_vp9_444, protocol version 9; colour at "
                "every pixel, more picture for its bytes)")
      ->needs(drag);
  cmd->add_option(
         "--drag-cycle", a->dragCycle,
         "with --drag: DRAG,REST seconds: each client drags DRAG seconds and rests REST, over and over, from a "
         "phase of its own (people drag and let go: each drag ends with a still Render of its last camera, as the "
         "viewer's release); the report gives each drag's wait for its first frame and the drags refused "
         "throughout (default: drag throughout)")
      ->expected(2)
      ->delimiter(',')
      ->check(CLI::Range(0.05, 3600.0))
      ->needs(drag);
  cmd->add_flag("--batch", a->batch,
                "the clients' scenes say \"batch\": true: work nobody watches as it happens, served after viewers' "
                "frames (a server that does not know the key gets the same scenes without it)");
  cmd->add_option("--json", a->jsonPath, "write the report as JSON");
  cmd->add_flag("--require-clean", a->requireClean,
                "exit non-zero unless every good request succeeded and every fault got its documented reply");
  addConnectOptions(cmd, a->connect);
  cmd->callback([a] {
    // The faulty clients misbehave below the message level, on bare sockets: in the clear only.
    if (a->connect.tls && a->faultClients > 0)
      throw std::invalid_argument("--fault-clients: faulty clients speak in the clear only, not with --tls");
    runLoad(*a);
  });
}

}  // namespace voxbrick::cli
