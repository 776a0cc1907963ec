// The render service's acceptor and lifecycle, and the wiring of its parts.
#include "server/Server.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <spdlog/spdlog.h>
#include <boost/asio.hpp>
#include <nlohmann/json.hpp>

#include "render/core/TransferFunctionPresets.h"
#include "render/engine/RenderEngine.h"
#include "server/AccessTokens.h"
#include "server/Admission.h"
#include "server/AuditLog.h"
#include "server/Datasets.h"
#include "server/EncoderQueue.h"
#include "server/ErrorReply.h"
#include "server/MessageHandler.h"
#include "server/OutputBudget.h"
#include "server/VideoMemory.h"
#include "server/PacsCatalog.h"
#include "server/Quotas.h"
#include "server/RenderScheduler.h"
#include "server/ServerStats.h"
#include "server/Session.h"
#include "server/TcpSession.h"
#include "server/TlsContext.h"
#include "server/Uploads.h"
#include "server/WebGate.h"
#include "server/WebSocketSession.h"

namespace voxbrick::server {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using nlohmann::json;

/// Clients that never read their last reply hold a stopping server up this long at most.
constexpr auto kShutdownGrace = std::chrono::seconds(5);

/// `config`, checked: values in range, the datasets directory present, the TLS files usable (before any GL context
/// is made, so that a bad file fails at once).
ServerConfig checked(ServerConfig config) {
  config.validate();
  std::error_code ec;
  if (!std::filesystem::is_directory(config.datasets, ec))
    throw std::runtime_error("datasets directory '" + config.datasets.string() + "' does not exist");
  if (config.tls.enabled()) makeServerTlsContext(config.tls);
  return config;
}

tcp::endpoint listenEndpoint(const std::string& host, int port) {
  boost::system::error_code ec;
  const asio::ip::address address = asio::ip::make_address(host, ec);
  if (ec) throw std::runtime_error("host '" + host + "' is not an IP address (e.g. 127.0.0.1, 0.0.0.0, ::1)");
  return tcp::endpoint(address, uint16_t(port));
}

/// Opens, binds and listens `acceptor` on `endpoint`; throws naming `what` and the address if it cannot.
void listen(tcp::acceptor& acceptor, const tcp::endpoint& endpoint, const std::string& what) {
  acceptor.open(endpoint.protocol());
  acceptor.set_option(tcp::acceptor::reuse_address(true));
  boost::system::error_code bindError;
  acceptor.bind(endpoint, bindError);
  if (bindError)
    throw std::runtime_error("cannot listen on " + endpoint.address().to_string() + ":" +
                             std::to_string(endpoint.port()) + " (" + what + "): " + bindError.message());
  acceptor.listen();
}

/// The address a connection is counted against, and whether it is loopback. An IPv4 client of a dual-stack socket
/// counts as its IPv4 address.
std::pair<std::string, bool> clientAddress(const tcp::socket& socket) {
  boost::system::error_code ec;
  asio::ip::address address = socket.remote_endpoint(ec).address();
  if (ec) return {"?", false};
  if (address.is_v6() && address.to_v6().is_v4_mapped())
    address = asio::ip::make_address_v4(asio::ip::v4_mapped, address.to_v6());
  return {address.to_string(), address.is_loopback()};
}

/// Whether `host` (a listen address) reaches this machine only.
bool loopbackOnly(const std::string& host) {
  boost::system::error_code ec;
  const asio::ip::address address = asio::ip::make_address(host, ec);
  return !ec && address.is_loopback();
}

Admission::Limits admissionLimits(const ServerConfig& config) {
  return {size_t(config.maxSessions), size_t(config.maxPendingConnections), size_t(config.maxConnectionsPerAddress)};
}

/// The limits a client or a load test may want to know (Stats "limits").
json limitsJson(const ServerConfig& config) {
  return {{"max_sessions", config.maxSessions},
          {"max_pending_connections", config.maxPendingConnections},
          {"max_connections_per_address", config.maxConnectionsPerAddress},
          {"loopback_exempt", config.loopbackExempt},
          {"hello_timeout_s", config.helloTimeoutS},
          {"idle_timeout_s", config.idleTimeoutS},
          {"read_timeout_s", config.readTimeoutS},
          {"write_timeout_s", config.writeTimeoutS},
          {"max_output_bytes", config.maxOutputBytes},
          {"pause_reading_bytes", config.pauseReadingBytes},
          {"max_total_output_bytes", config.maxTotalOutputBytes}};
}

}  // namespace

struct Server::Impl {
  Impl(const ServerConfig& c, std::vector<std::unique_ptr<render::FrameSource>> sources);
  /// Render threads post to sessions' strands: they stop before the io_context goes.
  ~Impl() { scheduler.stop(); }

  /// Accepts the next connection on `on` (the TCP or the HTTP acceptor), each on a strand of its own.
  void accept(tcp::acceptor& on);
  void onAccepted(const tcp::acceptor& on, tcp::socket socket);
  /// Registers a new connection from `address` made by `make` (given its ConnectionId), whatever its transport
  /// (`kind`, for the audit trail): admits or refuses it, evicts a pending one if the pool is full, and starts it.
  void adopt(const std::string& address, bool loopback, const std::string& kind,
             const std::function<std::shared_ptr<Session>(ConnectionId)>& make);
  void requestStop();
  /// Waits for SIGHUP: each reads the TLS files again (TlsContexts::reload); new handshakes use them.
  void awaitReload();
  /// Blocks until stop() or a signal asks for it.
  void waitForStopRequest();
  /// Refuses new sessions, ends the open ones with ShuttingDown, stops rendering, waits (kShutdownGrace at most)
  /// for the sessions to flush and close, then stops the I/O threads.
  void shutdown();
  void removeSession(ConnectionId id);
  /// A connection's Hello was accepted: none when it becomes a session (Admission::greet, its quotas, the render
  /// threads' capacity), else the Error that refuses it.
  std::optional<proto::Error> greet(ConnectionId id);
  /// What the server knows now besides its counters (for statsJson and metricsText).
  ServerStats::Gauges gauges() const;
  json statsJson() const;
  /// The Prometheus text of /metrics.
  std::string metricsText() const;

  const ServerConfig config;
  const tcp::endpoint endpoint;
  // Read once here: a preset named in a request never makes an I/O thread read a file.
  const render::TransferFunctionPresets presets;
  /// The access tokens and what each may see ([[tokens]], http.token, [access]).
  const std::shared_ptr<const AccessTokens> tokens;
  /// The audit trail ([audit] path), or one that records nothing.
  const std::unique_ptr<AuditLog> audit;
  const WebGate webGate;  ///< what the HTTP port serves, and who may open its WebSocket
  /// The TLS context of new connections on both ports (config.tls), read again on SIGHUP; null without TLS.
  const std::unique_ptr<TlsContexts> tls;
  DatasetRegistry datasets;
  /// Volumes clients send to become datasets ([upload]).
  Uploads uploads;
  /// The series of [[pacs]] as datasets, prepped into the PACS cache when first opened; null without [[pacs]].
  std::unique_ptr<PacsCatalog> pacs;
  ServerStats stats;
  OutputBudget output;
  /// The sessions' video encoders' memory (memory.video_mb); outlives every connection's stream.
  VideoMemory videoMemory;
  RenderScheduler scheduler;
  MessageHandler handler;
  asio::io_context io;
  /// Encodes sessions' frames by class (SessionServices::aside); its tasks post back to `io`, so it goes first.
  EncoderQueue encoders;
  /// Waits for uploads' preps (child processes; SessionServices::prepare); posts back to `io` as `encoders` does.
  asio::thread_pool preparers;
  /// The acceptor and the signals are used from this strand only.
  asio::strand<asio::io_context::executor_type> control;
  tcp::acceptor acceptor;
  tcp::acceptor httpAcceptor;  ///< open only with config.http
  asio::signal_set signals;
  asio::signal_set reloadSignal;  ///< SIGHUP, with TLS only
  SessionServices sessionServices;

  mutable std::mutex sessionsMutex;
  std::condition_variable sessionsChanged;
  /// Every open connection: sessions, connections waiting for Hello, refused ones until their error is written.
  std::map<ConnectionId, std::shared_ptr<Session>> sessions;
  Admission admission;        ///< guarded by sessionsMutex
  /// Each connection's address and whether it is loopback, for the quotas. Guarded by sessionsMutex.
  std::map<ConnectionId, std::pair<std::string, bool>> clients;
  Quotas quotas;
  uint64_t accepted = 0;      ///< connections so far: the next ConnectionId
  bool shuttingDown = false;  ///< guarded by sessionsMutex, so no session joins after the ShuttingDown round
  /// The HTTP port's open connections, and those of them that are sessions (the others are TCP); guarded by
  /// sessionsMutex.
  std::set<ConnectionId> webConnections, webSessions;

  std::mutex stopMutex;
  std::condition_variable stopRequested;
  bool stopAsked = false;
};

Server::Impl::Impl(const ServerConfig& c, std::vector<std::unique_ptr<render::FrameSource>> sources)
    : config(checked(c)),
      endpoint(listenEndpoint(config.host, config.port)),
      presets(render::TransferFunctionPresets::load(render::TransferFunction::configDirectory() / "tf")),
      tokens(std::make_shared<const AccessTokens>(config)),
      audit(config.auditPath.empty()
                ? std::make_unique<AuditLog>()
                : std::make_unique<AuditLog>(config.auditPath, config.auditMaxBytes, config.auditKeep)),
      webGate(config.httpOrigins, tokens, presets.json(false), [this] { return metricsText(); }),
      tls(config.tls.enabled() ? std::make_unique<TlsContexts>(config.tls) : nullptr),
      // Opened datasets are checked by the frame sources (the distributed mode: on every rank); the scheduler is
      // made before any dataset is opened.
      datasets(config.datasets, size_t(config.hostCacheMB) << 20,
               [this](const std::string& name) { scheduler.checkDataset(name); }),
      // Prepped by this very executable, as `voxbrick prep`; a chunk fills a message of the body limit.
      uploads(config.upload, config.datasets, std::filesystem::read_symlink("/proc/self/exe"),
              std::min<uint32_t>(config.maxMessageBytes - 4, 64u << 20)),
      output(config.maxTotalOutputBytes),
      videoMemory(uint64_t(config.videoMB) << 20),
      scheduler(std::move(sources), config.scheduler),
      handler(
          config, datasets, presets, stats, [this] { return statsJson(); }, tokens, audit.get(), &uploads),
      encoders(size_t(config.encodeThreads),
               {config.scheduler.interactiveWeight, config.scheduler.stillWeight, config.scheduler.batchWeight},
               size_t(std::max(0, config.scheduler.reservedInteractiveThreads))),
      preparers(size_t(config.upload.maxConcurrent)),
      control(asio::make_strand(io)),
      acceptor(control),
      httpAcceptor(control),
      signals(control, SIGINT, SIGTERM),
      reloadSignal(control),
      sessionServices{config,
                      proto::Limits{},
                      handler,
                      scheduler,
                      stats,
                      output,
                      [this](ConnectionId id) { removeSession(id); },
                      [this](ConnectionId id) { return greet(id); },
                      [this](ConnectionId id) -> std::optional<Submission> {
                        const auto refusal = quotas.takeFrame(id);
                        if (!refusal) return std::nullopt;
                        Submission busy;
                        busy.result = Submission::Result::Busy;
                        busy.retryAfterMs = refusal->retryAfterMs;
                        busy.why = refusal->why;
                        busy.quota = true;
                        return busy;
                      },
                      [this](ConnectionId id) { quotas.returnFrame(id); },
                      [this](FrameClass cls, std::function<void()> task) { encoders.post(cls, std::move(task)); },
                      tokens,
                      [this](ConnectionId id, const TokenGrant& grant) {
                        auto refusal = quotas.attachToken(id, grant);
                        if (refusal) stats.refused(Refusal::Quota);
                        return refusal;
                      },
                      audit.get(),
                      [this](std::function<void()> task) { asio::post(preparers, std::move(task)); },
                      &videoMemory},
      admission(admissionLimits(config)),
      quotas(config.quotas) {
  sessionServices.limits.maxBodyBytes = config.maxMessageBytes;
  if (!config.pacs.empty()) {
    PacsCacheConfig cache = config.pacsCache;
    if (cache.dir.empty()) cache.dir = config.datasets / ".pacs";  // hidden: never a dataset of the folder itself
    pacs = std::make_unique<PacsCatalog>(config.pacs, cache, std::filesystem::read_symlink("/proc/self/exe"));
    datasets.attach(pacs.get());
    spdlog::info("PACS: {} listed as datasets, cached in {} (up to {} MB)", config.pacs.size(), cache.dir.string(),
                 cache.maxMB);
  }
  if (uploads.enabled())
    spdlog::info("uploads: up to {} bytes each, {} at a time, by tokens that may upload", config.upload.maxBytes,
                 config.upload.maxConcurrent);
  listen(acceptor, endpoint, "TCP");
  if (config.http) listen(httpAcceptor, listenEndpoint(config.httpHost(), config.httpPort), "HTTP");
  if (tls) {
    spdlog::info("TLS on {}: {}", config.http ? "both ports" : "the TCP port", describeCertificate(config.tls.cert));
    if (!config.tls.ca.empty())
      spdlog::info("TLS: clients must present a certificate signed by a CA of {}", config.tls.ca.string());
    reloadSignal.add(SIGHUP);
  } else {
    // Off loopback without TLS, anyone on the path reads the frames, the dataset names and the access tokens.
    for (const auto& [what, host] : {std::pair<const char*, std::string>{"TCP", config.host},
                                     std::pair<const char*, std::string>{"HTTP", config.http ? config.httpHost() : ""}})
      if (!host.empty() && !loopbackOnly(host))
        spdlog::warn(
            "the {} port listens on {} without TLS: frames, dataset names and access tokens cross the "
            "network in clear text; give a certificate (--tls-cert and --tls-key, or [tls] in "
            "server.toml) or put a TLS proxy in front",
            what, host);
  }
  scheduler.start();
}

void Server::Impl::awaitReload() {
  reloadSignal.async_wait([this](boost::system::error_code ec, int) {
    if (ec) return;
    try {
      tls->reload();
      spdlog::info("SIGHUP: TLS certificate and key read again; new connections use {}",
                   describeCertificate(config.tls.cert));
    } catch (const std::exception& e) {
      spdlog::error("SIGHUP: the TLS files cannot be read again, the current ones stay in use: {}", e.what());
    }
    awaitReload();
  });
}

void Server::Impl::accept(tcp::acceptor& on) {
  on.async_accept(asio::make_strand(io), [this, &on](boost::system::error_code ec, tcp::socket socket) {
    if (ec) {
      if (ec != asio::error::operation_aborted) spdlog::warn("accept: {}", ec.message());
    } else {
      try {
        onAccepted(on, std::move(socket));
      } catch (const std::exception& e) {  // that connection is lost; the server goes on without it
        spdlog::error("accept: {}", e.what());
      }
    }
    bool stopping;
    {
      std::lock_guard lock(sessionsMutex);
      stopping = shuttingDown;
    }
    if (!stopping) accept(on);
  });
}

void Server::Impl::onAccepted(const tcp::acceptor& on, tcp::socket socket) {
  const auto [address, loopback] = clientAddress(socket);
  // Replies go out as soon as they are written: without it a frame's last TLS record waited for the client's
  // delayed acknowledgement of the ones before (Nagle), 25 ms more per frame over TLS (bench/results/server/tls-drag.md).
  boost::system::error_code noDelay;
  socket.set_option(tcp::no_delay(true), noDelay);  // a socket already reset: its session fails on its first read
  // A browser's connection is pending (not a session) from its accept, through its HTTP requests and the upgrade,
  // until its Hello: the same admission as a TCP connection.
  if (&on == &httpAcceptor)
    return adopt(address, loopback, tls ? "wss" : "ws", [&](ConnectionId id) -> std::shared_ptr<Session> {
      webConnections.insert(id);  // adopt() holds sessionsMutex
      if (tls)
        return std::make_shared<TlsWebSocketSession>(std::move(socket), tls->current(), sessionServices, webGate, id);
      return std::make_shared<PlainWebSocketSession>(std::move(socket), sessionServices, webGate, id);
    });
  adopt(address, loopback, tls ? "tls" : "tcp", [&](ConnectionId id) {
    return std::make_shared<TcpSession>(std::move(socket), sessionServices, id, tls ? tls->current() : nullptr);
  });
}

void Server::Impl::adopt(const std::string& address, bool loopback, const std::string& kind,
                         const std::function<std::shared_ptr<Session>(ConnectionId)>& make) {
  std::shared_ptr<Session> session, evicted;
  std::optional<proto::Error> refusal;
  Refusal reason = Refusal::Stopping;
  {
    std::lock_guard lock(sessionsMutex);
    const ConnectionId id{++accepted};
    session = make(id);
    sessions.emplace(id, session);  // refused ones too, until their error is written
    clients[id] = {address, loopback};
    if (shuttingDown) {
      refusal = errorMessage(proto::ErrorCode::ShuttingDown, "server is stopping");
    } else {
      const Admission::Verdict verdict = admission.admit(id, address, !(loopback && config.loopbackExempt));
      using Result = Admission::Verdict::Result;
      if (verdict.result == Result::TooManySessions) {
        reason = Refusal::Sessions;
        refusal = errorMessage(proto::ErrorCode::LimitExceeded,
                               "too many sessions (limit " + std::to_string(config.maxSessions) + ")");
      } else if (verdict.result == Result::TooManyFromAddress) {
        reason = Refusal::Address;
        refusal =
            errorMessage(proto::ErrorCode::LimitExceeded, "too many connections from " + address + " (limit " +
                                                              std::to_string(config.maxConnectionsPerAddress) + ")");
      }
      if (verdict.evicted) evicted = sessions.at(*verdict.evicted);
    }
  }
  if (refusal) {
    stats.refused(reason);
    spdlog::debug("{}: refused: {}", session->peer(), refusal->message);
    const std::string& peer = session->peer();
    audit->record({"refused", peer.substr(0, peer.find(' ')), kind, "", "", "on connect: " + refusal->message});
    session->end(std::move(*refusal));
    return;
  }
  if (evicted) {
    // The pending connections are full of clients that have not said Hello: the one waiting longest (of the
    // address with the most) gives way, so a client that says Hello at once always gets in.
    stats.refused(Refusal::PendingEvicted);
    spdlog::info("{}: closing: no Hello yet and {} connections wait for theirs", evicted->peer(),
                 config.maxPendingConnections);
    evicted->end(errorMessage(proto::ErrorCode::LimitExceeded, "too many connections waiting for Hello (limit " +
                                                                   std::to_string(config.maxPendingConnections) +
                                                                   "): the oldest gives way"));
  }
  spdlog::debug("{}: connected", session->peer());
  session->start();
}

std::optional<proto::Error> Server::Impl::greet(ConnectionId id) {
  std::lock_guard lock(sessionsMutex);
  const auto tooMany = [&] {
    return errorMessage(proto::ErrorCode::LimitExceeded,
                        "too many sessions (limit " + std::to_string(config.maxSessions) + ")");
  };
  const auto client = clients.find(id);
  const auto session = sessions.find(id);
  if (client == clients.end() || session == sessions.end()) {
    stats.refused(Refusal::Sessions);
    return tooMany();
  }
  // Over capacity, where so configured: more sessions drag than the render threads can keep at their minimum rate.
  // Otherwise the session is taken, and its first drag waits in line.
  if (const auto busy = config.scheduler.busyAtHello ? scheduler.refuseNewSession() : std::nullopt) {
    stats.refused(Refusal::Busy);
    return errorMessage(proto::ErrorCode::Busy, proto::busyMessage(busy->why, busy->retryAfterMs));
  }
  if (auto refusal =
          quotas.admit(id, client->second.first, client->second.second, session->second->accessGrant().get())) {
    stats.refused(Refusal::Quota);
    return errorMessage(proto::ErrorCode::LimitExceeded, *refusal);
  }
  if (!admission.greet(id)) {
    quotas.remove(id);
    stats.refused(Refusal::Sessions);
    return tooMany();
  }
  if (webConnections.count(id)) webSessions.insert(id);
  stats.add(ServerEvent::SessionAccepted);
  return std::nullopt;
}

void Server::Impl::removeSession(ConnectionId id) {
  {
    std::lock_guard lock(sessionsMutex);
    sessions.erase(id);
    clients.erase(id);
    admission.remove(id);
    quotas.remove(id);
    webConnections.erase(id);
    webSessions.erase(id);
  }
  sessionsChanged.notify_all();
}

void Server::Impl::requestStop() {
  {
    std::lock_guard lock(stopMutex);
    stopAsked = true;
  }
  stopRequested.notify_all();
}

void Server::Impl::waitForStopRequest() {
  std::unique_lock lock(stopMutex);
  stopRequested.wait(lock, [&] { return stopAsked; });
}

void Server::Impl::shutdown() {
  spdlog::info("shutting down");
  const auto deadline = std::chrono::steady_clock::now() + kShutdownGrace;
  std::vector<std::shared_ptr<Session>> open;
  {
    std::lock_guard lock(sessionsMutex);
    shuttingDown = true;
    for (const auto& [id, session] : sessions) open.push_back(session);
  }
  asio::post(control, [this] {
    boost::system::error_code ignored;
    acceptor.close(ignored);
    httpAcceptor.close(ignored);
    signals.cancel(ignored);
    reloadSignal.cancel(ignored);
  });
  for (const auto& session : open) session->end(errorMessage(proto::ErrorCode::ShuttingDown, "server is stopping"));
  scheduler.stop();
  {
    std::unique_lock lock(sessionsMutex);
    sessionsChanged.wait_until(lock, deadline, [&] { return sessions.empty(); });
  }
  uploads.cancelAll();  // preps still running (their sessions did not end in time) are stopped
  if (pacs) pacs->stop();
  encoders.join();      // frames being encoded post their end to the I/O threads, which still run
  preparers.join();
  io.stop();
}

ServerStats::Gauges Server::Impl::gauges() const {
  ServerStats::Gauges gauges;
  {
    std::lock_guard lock(sessionsMutex);
    gauges.activeSessions = admission.sessions();
    gauges.pendingConnections = admission.pending();
    gauges.webSocketSessions = webSessions.size();
    gauges.tcpSessions = gauges.activeSessions - std::min(gauges.activeSessions, gauges.webSocketSessions);
  }
  gauges.outputQueuedBytes = output.queued();
  gauges.outputPeakBytes = output.peak();
  gauges.outputLimitBytes = output.limit();
  gauges.limits = limitsJson(config);
  gauges.queuedSessions = scheduler.queuedSessions();
  gauges.draggingSessions = scheduler.interactiveSessions();
  gauges.interactiveCapacity = scheduler.interactiveCapacity();
  gauges.waitingToDrag = scheduler.waitingToDrag();
  gauges.dragTurnsEnded = scheduler.turnsEnded();
  gauges.rendersCancelled = scheduler.cancelled();
  gauges.datasets = datasets.opened();
  gauges.renderThreads = config.renderThreads;
  const RenderScheduler::GpuGauges gpu = scheduler.gpu();
  gauges.gpu = {gpu.bytes, gpu.peakBytes, gpu.renderersReleased};
  gauges.gpuBudgetBytes = size_t(config.gpuBudgetMB) << 20;
  gauges.video = {videoMemory.encoders(), videoMemory.bytes(),   videoMemory.peakBytes(),
                  videoMemory.limit(),    videoMemory.freed(),   videoMemory.refused()};
  gauges.queuedByClass = scheduler.queuedByClass();
  gauges.encodesByClass = encoders.queued();
  gauges.deviceBusyMs = scheduler.deviceBusyMs();
  gauges.deviceWaitMs = scheduler.deviceWaitMs();
  return gauges;
}

json Server::Impl::statsJson() const {
  json j = stats.toJson(gauges());
  if (pacs) j["pacs"] = pacs->toJson();
  return j;
}

std::string Server::Impl::metricsText() const { return stats.metricsText(gauges()); }

std::vector<std::unique_ptr<render::FrameSource>> makeLocalSources(const ServerConfig& config) {
  std::vector<std::unique_ptr<render::FrameSource>> sources;
  // The GPU budget is the server's: each thread's atlases, whichever datasets they hold, stay within its share.
  const size_t share = (size_t(config.gpuBudgetMB) << 20) / size_t(config.renderThreads);
  for (int i = 0; i < config.renderThreads; ++i) {
    sources.push_back(std::make_unique<render::RenderEngine>(render::RenderEngineOptions{config.backend, share}));
    sources.back()->releaseCurrent();
  }
  return sources;
}

Server::Server(const ServerConfig& config) : Server(config, makeLocalSources(checked(config))) {}

Server::Server(const ServerConfig& config, std::vector<std::unique_ptr<render::FrameSource>> sources)
    : mImpl(std::make_unique<Impl>(config, std::move(sources))) {}

Server::~Server() = default;

int Server::port() const { return mImpl->acceptor.local_endpoint().port(); }

int Server::httpPort() const { return mImpl->httpAcceptor.is_open() ? mImpl->httpAcceptor.local_endpoint().port() : 0; }

void Server::run() {
  Impl& s = *mImpl;
  // No I/O thread runs yet, so the acceptor and the signals may be used from here before they belong to `control`.
  s.signals.async_wait([&s](boost::system::error_code ec, int) {
    if (!ec) s.requestStop();
  });
  if (s.tls) s.awaitReload();
  s.accept(s.acceptor);
  if (s.httpAcceptor.is_open()) s.accept(s.httpAcceptor);
  if (s.pacs) s.pacs->start();
  std::vector<std::thread> ioThreads;
  for (int i = 0; i < s.config.ioThreads; ++i) ioThreads.emplace_back([&s] { s.io.run(); });
  // This thread runs the lifecycle, so that waiting for renders and sessions never blocks an I/O thread.
  s.waitForStopRequest();
  s.shutdown();
  for (std::thread& t : ioThreads) t.join();
}

void Server::stop() { mImpl->requestStop(); }

std::string Server::statsJson() const { return mImpl->statsJson().dump(2); }

}  // namespace voxbrick::server
