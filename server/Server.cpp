// The render service: acceptor, sessions, the latest-wins render queue and the render threads.
#include "server/Server.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "proto/Messages.h"
#include "render/Image.h"
#include "render/RenderEngine.h"
#include "render/RenderErrors.h"
#include "render/Scene.h"
#include "render/TransferFunction.h"
#include "server/Datasets.h"
#include "server/FrameImage.h"

namespace voxbrick::server {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

double msBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}
std::chrono::milliseconds seconds(double s) { return std::chrono::milliseconds(int64_t(s * 1000)); }

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

/// Latencies of recent frames and their completion times, for percentiles and frames per second.
class LatencyWindow {
 public:
  void record(double ms) {
    std::lock_guard lock(mMutex);
    mSamples.push_back({Clock::now(), ms});
    if (mSamples.size() > kKeep) mSamples.pop_front();
  }
  json toJson() const {
    std::lock_guard lock(mMutex);
    std::vector<double> ms;
    const auto now = Clock::now();
    int64_t recent = 0;
    for (const Sample& s : mSamples) {
      ms.push_back(s.ms);
      if (now - s.at < std::chrono::seconds(10)) ++recent;
    }
    std::sort(ms.begin(), ms.end());
    auto pct = [&](double p) { return ms.empty() ? 0.0 : ms[std::min(ms.size() - 1, size_t(p * double(ms.size())))]; };
    return {{"samples", ms.size()},
            {"p50", pct(0.50)},
            {"p95", pct(0.95)},
            {"p99", pct(0.99)},
            {"max", ms.empty() ? 0.0 : ms.back()},
            {"frames_per_s_last_10s", double(recent) / 10.0}};
  }

 private:
  struct Sample {
    Clock::time_point at;
    double ms;
  };
  static constexpr size_t kKeep = 8192;
  mutable std::mutex mMutex;
  std::deque<Sample> mSamples;
};

/// Capacity of a session's read buffer kept between messages.
constexpr size_t kKeptBodyBytes = 64 << 10;

/// Without coalescing (a benchmark setting), how many renders one session may have waiting.
constexpr size_t kMaxQueuedWithoutCoalescing = 64;

struct Counters {
  std::atomic<uint64_t> sessionsAccepted{0}, sessionsRefused{0}, messages{0}, renderRequests{0}, frames{0},
      renderErrors{0}, superseded{0}, protocolErrors{0}, timeouts{0}, slowClientsDropped{0};
};

}  // namespace

struct Session;

struct RenderJob {
  uint32_t requestId = 0;
  proto::Encoding encoding = proto::Encoding::Png;
  render::Scene scene;
  std::shared_ptr<const render::Dataset> dataset;
  Clock::time_point received;
};

struct Server::Impl {
  explicit Impl(const ServerConfig& c);

  ServerConfig config;
  proto::Limits limits;
  render::TransferFunctionPresets presets;
  DatasetRegistry datasets;
  asio::io_context io;
  tcp::acceptor acceptor{io};
  asio::signal_set signals{io, SIGINT, SIGTERM};
  asio::steady_timer shutdownDeadline{io};
  Clock::time_point started = Clock::now();
  Counters counters;
  LatencyWindow latency;
  std::atomic<bool> shuttingDown{false};

  mutable std::mutex sessionsMutex;
  std::set<std::shared_ptr<Session>> sessions;

  // The render queue: sessions with a pending request, served in turn; each session holds at most one pending
  // request (a newer one replaces it), so the queue is bounded by the number of sessions.
  mutable std::mutex queueMutex;
  std::condition_variable queueReady;
  std::deque<std::shared_ptr<Session>> ready;
  bool queueStopping = false;
  std::vector<std::thread> renderThreads;

  void accept();
  void beginShutdown();
  /// Polls until no session is left or `deadline` passes, then stops the I/O threads.
  void waitForSessions(Clock::time_point deadline);
  void removeSession(const std::shared_ptr<Session>& session);
  /// Queues `job`, setting `replaced` to the request it replaced (latest wins); false if the session's queue is
  /// full (only without coalescing).
  bool submit(const std::shared_ptr<Session>& session, RenderJob job, std::optional<RenderJob>& replaced);
  void renderLoop(std::unique_ptr<render::RenderEngine> engine, int index);
  json statsJson() const;
};

/// One client connection. Every member function runs on the session's strand (its socket's executor), except the
/// queue fields, which Server::Impl guards with queueMutex, and `alive`, read by render threads.
struct Session : std::enable_shared_from_this<Session> {
  Session(Server::Impl& s, tcp::socket sock)
      : server(s), socket(std::move(sock)), readTimer(socket.get_executor()), writeTimer(socket.get_executor()) {
    boost::system::error_code ec;
    const auto endpoint = socket.remote_endpoint(ec);
    peer = ec ? "?" : endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
  }

  Server::Impl& server;
  tcp::socket socket;
  asio::steady_timer readTimer, writeTimer;
  std::string peer;
  std::array<uint8_t, proto::kHeaderBytes> headerBytes{};
  proto::Header header;
  std::vector<uint8_t> body;
  bool greeted = false;
  std::shared_ptr<const render::Dataset> dataset;
  std::deque<std::vector<uint8_t>> outbox;
  uint64_t outboxBytes = 0;
  bool writing = false, closing = false, closed = false, readingBody = false;
  int outstandingRenders = 0;
  std::atomic<bool> alive{true};
  // Guarded by Server::Impl::queueMutex: requests received and not started (at most one when coalescing).
  std::deque<RenderJob> pending;
  bool queued = false;

  void start() { readHeader(); }

  void armReadTimer(double s) {
    readTimer.expires_after(seconds(s));
    readTimer.async_wait([self = shared_from_this()](boost::system::error_code ec) {
      if (!ec) self->onReadTimeout();
    });
  }

  void onReadTimeout() {
    if (closed || closing) return;
    if (!readingBody && outstandingRenders > 0) {  // the client is waiting for us, not idle
      armReadTimer(server.config.idleTimeoutS);
      return;
    }
    server.counters.timeouts++;
    const std::string what = readingBody ? "message not completed within " + std::to_string(server.config.readTimeoutS) + " s"
                                         : "idle for " + std::to_string(server.config.idleTimeoutS) + " s";
    spdlog::info("{}: closing: {}", peer, what);
    sendError(0, proto::ErrorCode::Timeout, what);
    closeAfterFlush();
  }

  void readHeader() {
    if (closing || closed) return;
    readingBody = false;
    armReadTimer(server.config.idleTimeoutS);
    asio::async_read(socket, asio::buffer(headerBytes),
                     [self = shared_from_this()](boost::system::error_code ec, size_t) { self->onHeader(ec); });
  }

  void onHeader(boost::system::error_code ec) {
    if (ec) return close();
    try {
      header = proto::decodeHeader(std::span<const uint8_t, proto::kHeaderBytes>(headerBytes), server.limits);
    } catch (const proto::ProtocolError& e) {
      // Without a trustworthy header the stream cannot be resynchronised: reply and close.
      server.counters.protocolErrors++;
      spdlog::info("{}: {} ({}), closing", peer, e.what(), proto::errorCodeName(e.code()));
      sendError(0, e.code(), e.what());
      return closeAfterFlush();
    }
    body.resize(header.bodyBytes);  // at most limits.maxBodyBytes, checked by decodeHeader
    readingBody = true;
    armReadTimer(server.config.readTimeoutS);
    asio::async_read(socket, asio::buffer(body),
                     [self = shared_from_this()](boost::system::error_code e, size_t) { self->onBody(e); });
  }

  void onBody(boost::system::error_code ec) {
    if (ec) return close();
    readTimer.cancel();
    server.counters.messages++;
    std::optional<proto::Message> message;
    try {
      message = proto::decodeBody(header, body, server.limits);
    } catch (const proto::ProtocolError& e) {
      // The length was valid, so the next message starts where this one ended: the session goes on.
      server.counters.protocolErrors++;
      spdlog::debug("{}: {} ({})", peer, e.what(), proto::errorCodeName(e.code()));
      sendError(header.requestId, e.code(), e.what());
    }
    // Requests are small: the buffer is reused across them, and given back only after a large one.
    if (body.capacity() > kKeptBodyBytes) body = {};
    body.clear();
    if (message) handle(*message);
    readHeader();
  }

  void handle(const proto::Message& message) {
    const uint32_t id = header.requestId;
    if (const auto* hello = std::get_if<proto::Hello>(&message)) {
      if (greeted) return sendError(id, proto::ErrorCode::UnexpectedMessage, "Hello was already received");
      if (hello->minVersion > proto::kVersion || hello->maxVersion < proto::kVersion) {
        sendError(id, proto::ErrorCode::UnsupportedVersion,
                  "client speaks versions " + std::to_string(hello->minVersion) + ".." +
                      std::to_string(hello->maxVersion) + ", server speaks " + std::to_string(proto::kVersion));
        return closeAfterFlush();
      }
      greeted = true;
      spdlog::debug("{}: hello from '{}'", peer, hello->client);
      proto::Capabilities caps;
      caps.server = "voxbrick 0.1.0";
      caps.maxMessageBytes = server.config.maxMessageBytes;
      caps.maxImageSide = uint32_t(server.config.maxImageSide);
      caps.maxQueuedPerSession = server.config.coalesce ? 1 : uint32_t(kMaxQueuedWithoutCoalescing);
      caps.encodings = {proto::Encoding::RawRgba8, proto::Encoding::Png, proto::Encoding::ZstdRgba8};
      return send(caps, id);
    }
    if (std::holds_alternative<proto::Goodbye>(message)) return closeAfterFlush();
    if (!greeted) return sendError(id, proto::ErrorCode::UnexpectedMessage, "send Hello first");
    if (std::holds_alternative<proto::ListDatasets>(message)) return send(proto::DatasetList{server.datasets.names()}, id);
    if (const auto* open = std::get_if<proto::OpenDataset>(&message)) {
      try {
        dataset = server.datasets.open(open->name);
      } catch (const DatasetNotFound& e) {
        return sendError(id, proto::ErrorCode::UnknownDataset, e.what());
      } catch (const std::exception& e) {
        spdlog::error("dataset '{}' cannot be opened: {}", open->name, e.what());
        return sendError(id, proto::ErrorCode::Internal, "dataset '" + open->name + "' cannot be opened: " + e.what());
      }
      return send(proto::DatasetInfo{dataset->name(), dataset->infoJson()}, id);
    }
    if (const auto* request = std::get_if<proto::RenderRequest>(&message)) return onRender(*request, id);
    if (std::holds_alternative<proto::GetStats>(message)) return send(proto::Stats{server.statsJson().dump(2)}, id);
    sendError(id, proto::ErrorCode::UnexpectedMessage,
              std::string(proto::messageTypeName(proto::messageType(message))) + " is sent by servers, not clients");
  }

  void onRender(const proto::RenderRequest& request, uint32_t id) {
    server.counters.renderRequests++;
    if (!dataset) return sendError(id, proto::ErrorCode::UnexpectedMessage, "open a dataset before rendering");
    RenderJob job;
    job.requestId = id;
    job.encoding = request.encoding;
    job.dataset = dataset;
    job.received = Clock::now();
    try {
      job.scene = render::Scene::fromJson(request.sceneJson, "scene", server.presets);
    } catch (const std::exception& e) {
      return sendError(id, proto::ErrorCode::InvalidScene, e.what());
    }
    if (job.scene.width > server.config.maxImageSide || job.scene.height > server.config.maxImageSide)
      return sendError(id, proto::ErrorCode::LimitExceeded,
                       "image " + std::to_string(job.scene.width) + "x" + std::to_string(job.scene.height) +
                           " exceeds this server's limit of " + std::to_string(server.config.maxImageSide) + " per side");
    ++outstandingRenders;
    std::optional<RenderJob> replaced;
    if (!server.submit(shared_from_this(), std::move(job), replaced)) {
      --outstandingRenders;
      return sendError(id, proto::ErrorCode::LimitExceeded,
                       "more than " + std::to_string(kMaxQueuedWithoutCoalescing) + " renders queued");
    }
    if (replaced) {
      --outstandingRenders;
      server.counters.superseded++;
      sendError(replaced->requestId, proto::ErrorCode::Superseded,
                "request " + std::to_string(replaced->requestId) + " was replaced by request " + std::to_string(id) +
                    " before it started");
    }
  }

  /// A render thread's result, on the strand.
  void deliver(uint32_t id, proto::Message reply, Clock::time_point received) {
    --outstandingRenders;
    if (closed) return;
    if (std::holds_alternative<proto::Frame>(reply)) {
      server.counters.frames++;
      server.latency.record(msBetween(received, Clock::now()));
    } else {
      server.counters.renderErrors++;
    }
    send(reply, id);
  }

  void sendError(uint32_t id, proto::ErrorCode code, const std::string& message) {
    send(proto::Error{code, message.substr(0, 4096)}, id);
  }

  void send(const proto::Message& message, uint32_t id) {
    if (closed) return;
    std::vector<uint8_t> bytes = proto::encode(message, id);
    if (outboxBytes + bytes.size() > server.config.maxOutputBytes) {
      server.counters.slowClientsDropped++;
      spdlog::warn("{}: {} bytes of replies not read, dropping the session", peer, outboxBytes);
      return close();
    }
    outboxBytes += bytes.size();
    outbox.push_back(std::move(bytes));
    if (!writing) writeNext();
  }

  void writeNext() {
    writing = true;
    writeTimer.expires_after(seconds(server.config.writeTimeoutS));
    writeTimer.async_wait([self = shared_from_this()](boost::system::error_code ec) {
      if (ec || self->closed) return;
      self->server.counters.slowClientsDropped++;
      spdlog::info("{}: a reply was not taken within {} s, closing", self->peer, self->server.config.writeTimeoutS);
      self->close();
    });
    asio::async_write(socket, asio::buffer(outbox.front()),
                      [self = shared_from_this()](boost::system::error_code ec, size_t) {
                        self->writeTimer.cancel();
                        if (ec) return self->close();
                        self->outboxBytes -= self->outbox.front().size();
                        self->outbox.pop_front();
                        if (!self->outbox.empty()) return self->writeNext();
                        self->writing = false;
                        if (self->closing) self->close();
                      });
  }

  /// Stops reading; closes once every queued reply is written.
  void closeAfterFlush() {
    closing = true;
    if (!writing) close();
  }

  void close() {
    if (closed) return;
    closed = true;
    alive = false;
    readTimer.cancel();
    writeTimer.cancel();
    boost::system::error_code ignored;
    socket.shutdown(tcp::socket::shutdown_both, ignored);
    socket.close(ignored);
    server.removeSession(shared_from_this());
  }
};

Server::Impl::Impl(const ServerConfig& c)
    : config(c),
      presets(render::TransferFunctionPresets::load(render::TransferFunction::configDirectory() / "tf")),
      datasets(c.datasets, size_t(c.hostCacheMB) << 20) {
  config.validate();
  limits.maxBodyBytes = config.maxMessageBytes;
  std::error_code ec;
  if (!std::filesystem::is_directory(config.datasets, ec))
    throw std::runtime_error("datasets directory '" + config.datasets.string() + "' does not exist");
  const render::Backend backend = config.backend;
  boost::system::error_code addressError;
  const asio::ip::address address = asio::ip::make_address(config.host, addressError);
  if (addressError) throw std::runtime_error("host '" + config.host + "' is not an IP address (e.g. 127.0.0.1, 0.0.0.0, ::1)");
  const tcp::endpoint endpoint(address, uint16_t(config.port));
  // Contexts are made and the port bound before any thread starts, so that a machine without GL or a port in use
  // fails at startup with an error, not with threads left running.
  std::vector<std::unique_ptr<render::RenderEngine>> engines;
  for (int i = 0; i < config.renderThreads; ++i) {
    engines.push_back(std::make_unique<render::RenderEngine>(backend, size_t(config.gpuBudgetMB) << 20));
    engines.back()->releaseCurrent();
  }
  spdlog::info("render threads: {} x {}", config.renderThreads, engines.front()->describe());
  acceptor.open(endpoint.protocol());
  acceptor.set_option(tcp::acceptor::reuse_address(true));
  boost::system::error_code bindError;
  acceptor.bind(endpoint, bindError);
  if (bindError)
    throw std::runtime_error("cannot listen on " + config.host + ":" + std::to_string(config.port) + ": " +
                             bindError.message());
  acceptor.listen();
  for (int i = 0; i < config.renderThreads; ++i)
    renderThreads.emplace_back(&Impl::renderLoop, this, std::move(engines[size_t(i)]), i);
}

void Server::Impl::accept() {
  acceptor.async_accept(asio::make_strand(io), [this](boost::system::error_code ec, tcp::socket socket) {
    if (ec) {
      if (ec != asio::error::operation_aborted) spdlog::warn("accept: {}", ec.message());
      if (!shuttingDown) accept();
      return;
    }
    auto session = std::make_shared<Session>(*this, std::move(socket));
    bool refused = false;
    {
      std::lock_guard lock(sessionsMutex);
      refused = shuttingDown || int(sessions.size()) >= config.maxSessions;
      sessions.insert(session);  // refused ones too, until their error is written
    }
    asio::post(session->socket.get_executor(), [this, session, refused] {
      if (refused) {
        counters.sessionsRefused++;
        session->sendError(0, shuttingDown ? proto::ErrorCode::ShuttingDown : proto::ErrorCode::LimitExceeded,
                           shuttingDown ? "server is stopping"
                                        : "too many sessions (limit " + std::to_string(config.maxSessions) + ")");
        session->closeAfterFlush();
      } else {
        counters.sessionsAccepted++;
        spdlog::debug("{}: connected", session->peer);
        session->start();
      }
    });
    if (!shuttingDown) accept();
  });
}

void Server::Impl::removeSession(const std::shared_ptr<Session>& session) {
  std::lock_guard lock(sessionsMutex);
  sessions.erase(session);
}

bool Server::Impl::submit(const std::shared_ptr<Session>& session, RenderJob job, std::optional<RenderJob>& replaced) {
  {
    std::lock_guard lock(queueMutex);
    if (config.coalesce && !session->pending.empty()) {
      replaced = std::move(session->pending.front());
      session->pending.clear();
    }
    if (session->pending.size() >= kMaxQueuedWithoutCoalescing) return false;
    session->pending.push_back(std::move(job));
    if (!session->queued) {
      ready.push_back(session);
      session->queued = true;
    }
  }
  queueReady.notify_one();
  return true;
}

void Server::Impl::renderLoop(std::unique_ptr<render::RenderEngine> engine, int index) {
  // The engine's renderers hold GL objects: they live and die on this thread, with its context current.
  engine->makeCurrent();
  for (;;) {
    std::shared_ptr<Session> session;
    RenderJob job;
    {
      std::unique_lock lock(queueMutex);
      queueReady.wait(lock, [&] { return queueStopping || !ready.empty(); });
      if (queueStopping) break;
      session = std::move(ready.front());
      ready.pop_front();
      job = std::move(session->pending.front());
      session->pending.pop_front();
      // Sessions take turns: one with more queued goes to the back.
      session->queued = !session->pending.empty();
      if (session->queued) ready.push_back(session);
    }
    if (!session->alive) continue;
    const auto start = Clock::now();
    proto::Message reply;
    try {
      render::FrameStats stats;
      const render::ImageF image = engine->render(job.dataset, job.scene, &stats);
      const auto encodeStart = Clock::now();
      proto::Frame frame;
      frame.width = uint32_t(image.width);
      frame.height = uint32_t(image.height);
      frame.encoding = job.encoding;
      frame.payload = encodeFrameImage(render::toImage8(image), job.encoding);
      json statsJson = stats.toJson();
      statsJson["queue_ms"] = msBetween(job.received, start);
      statsJson["encode_ms"] = msBetween(encodeStart, Clock::now());
      statsJson["render_thread"] = index;
      frame.statsJson = statsJson.dump();
      reply = std::move(frame);
    } catch (const render::RenderInputError& e) {
      reply = proto::Error{proto::ErrorCode::InvalidScene, e.what()};
    } catch (const std::exception& e) {
      spdlog::error("render of request {} on '{}' failed: {}", job.requestId, job.dataset->name(), e.what());
      reply = proto::Error{proto::ErrorCode::Internal, std::string("render failed: ") + e.what()};
    }
    asio::post(session->socket.get_executor(),
               [session, id = job.requestId, r = std::move(reply), received = job.received]() mutable {
                 session->deliver(id, std::move(r), received);
               });
  }
}

void Server::Impl::beginShutdown() {
  if (shuttingDown.exchange(true)) return;
  spdlog::info("shutting down");
  boost::system::error_code ignored;
  acceptor.close(ignored);
  signals.cancel();
  {
    std::lock_guard lock(queueMutex);
    queueStopping = true;
  }
  queueReady.notify_all();
  std::vector<std::shared_ptr<Session>> open;
  {
    std::lock_guard lock(sessionsMutex);
    open.assign(sessions.begin(), sessions.end());
  }
  for (const auto& session : open)
    asio::post(session->socket.get_executor(), [session] {
      session->sendError(0, proto::ErrorCode::ShuttingDown, "server is stopping");
      session->closeAfterFlush();
    });
  // Stop once every session has closed; clients that never read their last reply hold the server up 5 s at most.
  waitForSessions(Clock::now() + std::chrono::seconds(5));
}

void Server::Impl::waitForSessions(Clock::time_point deadline) {
  bool empty;
  {
    std::lock_guard lock(sessionsMutex);
    empty = sessions.empty();
  }
  if (empty || Clock::now() >= deadline) return io.stop();
  shutdownDeadline.expires_after(std::chrono::milliseconds(20));
  shutdownDeadline.async_wait([this, deadline](boost::system::error_code ec) {
    if (!ec) waitForSessions(deadline);
  });
}

json Server::Impl::statsJson() const {
  const auto [rss, peak] = residentMemory();
  json sets = json::array();
  for (const auto& d : datasets.opened()) {
    const store::CacheStats c = d->cacheStats();
    const double lookups = double(c.hits + c.misses);
    sets.push_back({{"name", d->name()},
                    {"cache", {{"hits", c.hits},
                               {"misses", c.misses},
                               {"hit_rate", lookups > 0 ? double(c.hits) / lookups : 0.0},
                               {"resident_bytes", c.residentBytes},
                               {"budget_bytes", c.budgetBytes},
                               {"evictions", c.evictions}}}});
  }
  size_t active = 0, queued = 0;
  {
    std::lock_guard lock(sessionsMutex);
    active = sessions.size();
  }
  {
    std::lock_guard lock(queueMutex);
    queued = ready.size();
  }
  const double uptime = msBetween(started, Clock::now()) / 1000;
  return {{"uptime_s", uptime},
          {"sessions", {{"active", active},
                        {"accepted", counters.sessionsAccepted.load()},
                        {"refused", counters.sessionsRefused.load()},
                        {"timed_out", counters.timeouts.load()},
                        {"dropped_slow", counters.slowClientsDropped.load()}}},
          {"messages", counters.messages.load()},
          {"protocol_errors", counters.protocolErrors.load()},
          {"renders", {{"requested", counters.renderRequests.load()},
                       {"frames", counters.frames.load()},
                       {"superseded", counters.superseded.load()},
                       {"errors", counters.renderErrors.load()},
                       {"queued", queued},
                       {"frames_per_s", uptime > 0 ? double(counters.frames.load()) / uptime : 0.0}}},
          {"latency_ms", latency.toJson()},
          {"datasets", sets},
          {"memory", {{"rss_bytes", rss}, {"peak_rss_bytes", peak}}},
          {"render_threads", config.renderThreads}};
}

Server::Server(const ServerConfig& config) : mImpl(std::make_unique<Impl>(config)) {}

Server::~Server() {
  stop();
  {
    std::lock_guard lock(mImpl->queueMutex);
    mImpl->queueStopping = true;
  }
  mImpl->queueReady.notify_all();
  for (std::thread& t : mImpl->renderThreads)
    if (t.joinable()) t.join();
}

int Server::port() const { return mImpl->acceptor.local_endpoint().port(); }

void Server::run() {
  Impl& s = *mImpl;
  s.signals.async_wait([&s](boost::system::error_code ec, int) {
    if (!ec) s.beginShutdown();
  });
  s.accept();
  std::vector<std::thread> io;
  for (int i = 1; i < s.config.ioThreads; ++i) io.emplace_back([&s] { s.io.run(); });
  s.io.run();
  for (std::thread& t : io) t.join();
  {
    std::lock_guard lock(s.queueMutex);
    s.queueStopping = true;
  }
  s.queueReady.notify_all();
  for (std::thread& t : s.renderThreads)
    if (t.joinable()) t.join();
}

void Server::stop() {
  asio::post(mImpl->io, [impl = mImpl.get()] { impl->beginShutdown(); });
}

std::string Server::statsJson() const { return mImpl->statsJson().dump(2); }

}  // namespace voxbrick::server
