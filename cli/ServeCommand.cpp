// `voxbrick serve [--config config/server.toml | --no-config] [overrides]`: the render service.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <atomic>
#include <csignal>

#include <unistd.h>

#include <spdlog/spdlog.h>

#include "cli/Commands.h"
#include "cli/MpiOptions.h"
#include "distributed/Cluster.h"
#include "distributed/ServeRanks.h"
#include "render/core/TransferFunction.h"
#include "render/engine/ReplayFrameSource.h"
#include "server/Server.h"
#include "server/ServerConfig.h"
#include "server/TlsContext.h"

namespace voxbrick::cli {
namespace {

struct ServeArgs {
  std::string config, host, datasets, backend, logLevel, portFile;
  int http = -1;  ///< --http PORT; -1: as configured
  std::string httpBind, httpToken, httpPortFile;
  std::string tlsCert, tlsKey, tlsCa, auditLog;
  std::vector<std::string> httpOrigins;
  int port = -1, renderThreads = 0, ioThreads = 0, maxSessions = 0, maxImageSide = 0;
  double maxRenderMSamples = 0;
  int maxPending = 0, maxPerAddress = -1;
  double idleTimeout = 0, readTimeout = 0, writeTimeout = 0, helloTimeout = 0;
  int64_t maxTotalOutputMB = 0;
  bool noCoalesce = false, noConfig = false;
  int64_t hostCacheMB = 0, gpuBudgetMB = 0, videoMB = -1, maxMessageBytes = 0;
  double uploadMaxMB = -1;  ///< --upload-max-mb; -1: as configured
  MpiArgs mpi;  ///< --mpi: sort-last across the ranks of mpirun: rank 0 serves, the others draw parts
  std::string replayFrames;  ///< --replay-frames DIR: frames drawn beforehand instead of drawing (benchmarks)
  double replayDrawMs = 0;   ///< --replay-draw-ms: the time each replayed frame takes
};

/// Set by SIGTERM or SIGINT on a worker rank of `serve --mpi` (rank 0's server handles its own signals).
std::atomic<bool> gWorkerStop{false};
extern "C" void onWorkerSignal(int) { gWorkerStop = true; }

/// The configuration file serve reads: --config, else server.toml in the configuration directory (the source tree's
/// config/ beside build/, an installed PREFIX/share/voxbrick, or $VOXBRICK_CONFIG_DIR) if there is one and
/// --no-config was not given; empty: the built-in defaults.
std::string configFile(const ServeArgs& a) {
  if (!a.config.empty() || a.noConfig) return a.config;
  const std::filesystem::path found = render::TransferFunction::configDirectory() / "server.toml";
  std::error_code ec;
  return std::filesystem::is_regular_file(found, ec) ? found.string() : std::string();
}

/// Writes `port` to `file` whole under a temporary name, then renames it: a script polling for it never reads half
/// a number.
void writePortFile(const std::string& file, int port) {
  const std::string tmp = file + ".tmp";
  std::ofstream(tmp) << port << "\n";
  std::rename(tmp.c_str(), file.c_str());
}

/// The address a person opens to reach the viewer. It never carries the access token (a token is not to be logged):
/// with one, the page is opened with ?token=TOKEN added, which it passes on to /ws.
std::string viewerUrl(const server::ServerConfig& c, int port) {
  std::string host = c.httpHost();
  if (host == "0.0.0.0" || host == "::") {  // every interface: this machine's name
    char name[256] = {};
    host = ::gethostname(name, sizeof name - 1) == 0 && name[0] ? name : "localhost";
  } else if (host.find(':') != std::string::npos) {
    host = "[" + host + "]";
  }
  return std::string(c.tls.enabled() ? "https://" : "http://") + host + ":" + std::to_string(port) + "/";
}

void serveWith(const ServeArgs& a, const server::ServerConfig& c,
               std::vector<std::unique_ptr<render::FrameSource>> sources);
void serveMpi(const ServeArgs& a, server::ServerConfig c);

void runServe(const ServeArgs& a) {
  const std::string file = configFile(a);
  server::ServerConfig c = file.empty() ? server::ServerConfig{} : server::ServerConfig::load(file);
  if (!a.host.empty()) c.host = a.host;
  if (a.port >= 0) c.port = a.port;
  if (!a.datasets.empty()) c.datasets = a.datasets;
  if (!a.backend.empty()) c.backend = server::ServerConfig::parseBackend(a.backend, "--backend");
  if (!a.logLevel.empty()) c.logLevel = a.logLevel;
  if (a.renderThreads > 0) c.renderThreads = a.renderThreads;
  if (a.ioThreads > 0) c.ioThreads = a.ioThreads;
  if (a.maxSessions > 0) c.maxSessions = a.maxSessions;
  if (a.maxImageSide > 0) c.maxImageSide = a.maxImageSide;
  if (a.maxRenderMSamples > 0) c.maxRenderMSamples = a.maxRenderMSamples;
  if (a.maxMessageBytes > 0) c.maxMessageBytes = uint32_t(std::min<int64_t>(a.maxMessageBytes, UINT32_MAX));
  if (a.idleTimeout > 0) c.idleTimeoutS = a.idleTimeout;
  if (a.readTimeout > 0) c.readTimeoutS = a.readTimeout;
  if (a.writeTimeout > 0) c.writeTimeoutS = a.writeTimeout;
  if (a.helloTimeout > 0) c.helloTimeoutS = a.helloTimeout;
  if (a.maxPending > 0) c.maxPendingConnections = a.maxPending;
  if (a.maxPerAddress >= 0) c.maxConnectionsPerAddress = a.maxPerAddress;
  if (a.maxTotalOutputMB > 0) c.maxTotalOutputBytes = uint64_t(a.maxTotalOutputMB) << 20;
  if (a.hostCacheMB > 0) c.hostCacheMB = a.hostCacheMB;
  if (a.noCoalesce) c.scheduler.coalesce = false;
  if (a.gpuBudgetMB > 0) c.gpuBudgetMB = a.gpuBudgetMB;
  if (a.videoMB >= 0) c.videoMB = a.videoMB;
  if (a.http >= 0) {
    c.http = true;
    c.httpPort = a.http;
  }
  if (!a.httpBind.empty()) c.httpBind = a.httpBind;
  if (!a.httpOrigins.empty()) c.httpOrigins = a.httpOrigins;
  if (!a.httpToken.empty()) c.httpToken = a.httpToken;
  if (!a.tlsCert.empty()) c.tls.cert = a.tlsCert;
  if (!a.tlsKey.empty()) c.tls.key = a.tlsKey;
  if (!a.tlsCa.empty()) c.tls.ca = a.tlsCa;
  if (!a.auditLog.empty()) c.auditPath = a.auditLog;
  if (a.uploadMaxMB >= 0) c.upload.maxBytes = uint64_t(a.uploadMaxMB * double(1 << 20));
  c.validate();
  // TLS files that cannot be used are said before the render threads' GL contexts are made (the server reads them
  // again when it starts).
  if (c.tls.enabled()) server::makeServerTlsContext(c.tls);
  spdlog::set_level(spdlog::level::from_str(c.logLevel));
  spdlog::set_pattern("[%Y-%m-%d %H:%M:%S.%e] [%l] %v");

  if (!c.http && !a.httpPortFile.empty())
    throw std::runtime_error("--http-port-file needs --http PORT (or http.port in the configuration)");
  spdlog::info("configuration: {}", file.empty() ? std::string("the built-in defaults") : file);
  spdlog::info("{}", hugePagesForMallocNote());
  if (!a.replayFrames.empty()) {
    if (a.mpi.mpi) throw std::runtime_error("--replay-frames draws nothing, so it cannot be shared across ranks (--mpi)");
    // Read before the server starts, so that a bad directory is refused at once, naming what is wrong.
    const auto frames = std::make_shared<const render::ReplayFrames>(a.replayFrames);
    std::vector<std::unique_ptr<render::FrameSource>> sources;
    const auto drawTime = std::chrono::microseconds(int64_t(a.replayDrawMs * 1000.0));
    for (int i = 0; i < c.renderThreads; ++i)
      sources.push_back(std::make_unique<render::ReplayFrameSource>(frames, drawTime));
    return serveWith(a, c, std::move(sources));
  }
  if (a.mpi.mpi) return serveMpi(a, c);
  serveWith(a, c, server::makeLocalSources(c));
}

void serveWith(const ServeArgs& a, const server::ServerConfig& c,
               std::vector<std::unique_ptr<render::FrameSource>> sources) {
  server::Server server(c, std::move(sources));
  spdlog::info("serving datasets from {} on {}:{}", c.datasets.string(), c.host, server.port());
  std::printf("listening on %s:%d\n", c.host.c_str(), server.port());
  std::fflush(stdout);
  if (c.http) {
    const std::string tokenNote = c.httpToken.empty() ? "" : " (add ?token= and the access token)";
    spdlog::info("viewer: open {}{}", viewerUrl(c, server.httpPort()), tokenNote);
    std::printf("viewer at %s%s\n", viewerUrl(c, server.httpPort()).c_str(), tokenNote.c_str());
    std::fflush(stdout);
  }
  if (!a.httpPortFile.empty()) writePortFile(a.httpPortFile, server.httpPort());
  if (!a.portFile.empty()) writePortFile(a.portFile, server.port());
  server.run();
  spdlog::info("stopped");
}

/// `serve --mpi`: rank 0 serves with one render thread whose grid frames go across every rank; the other ranks draw
/// their parts until rank 0 tells them to quit (docs/distributed.md).
void serveMpi(const ServeArgs& a, server::ServerConfig c) {
  distributed::MpiSession mpi;
  distributed::ServeRankOptions options;
  options.datasets = c.datasets;
  options.frames.composite = compositeOptions(a.mpi);
  options.hostCacheBytes = size_t(c.hostCacheMB) << 20;
  options.engine = render::RenderEngineOptions{c.backend, size_t(c.gpuBudgetMB) << 20};
  if (mpi.rank() != 0) {
    std::signal(SIGTERM, onWorkerSignal);
    std::signal(SIGINT, onWorkerSignal);
    if (!distributed::runWorker(MPI_COMM_WORLD, options, gWorkerStop)) mpi.abandon();
    return;
  }
  c.renderThreads = 1;  // one frame across the ranks at a time
  auto leader = std::make_shared<distributed::FrameLeader>(MPI_COMM_WORLD, options);
  spdlog::info("distributed mode: {} ranks, rank 0 serves", mpi.size());
  try {
    std::vector<std::unique_ptr<render::FrameSource>> sources;
    sources.push_back(std::make_unique<distributed::SortLastSource>(leader, MPI_COMM_WORLD, options));
    sources.back()->releaseCurrent();
    serveWith(a, c, std::move(sources));
  } catch (...) {
    leader->quit();
    throw;
  }
  if (!leader->quit()) mpi.abandon();  // a rank was lost: MPI_Finalize could wait for it for ever
}

std::string shown(double v) { return formatNumber(v); }
std::string shown(const std::string& v) { return v; }

/// The end of a help text for an option that overrides key `key` of the configuration file: "(default VALUE, or
/// KEY of the configuration)", VALUE the built-in default, ServerConfig's own (the shipped server.toml says the
/// same: a test holds them equal).
template <typename T>
std::string configured(const T& value, const char* key) {
  return " (default " + shown(value) + ", or " + key + " of the configuration)";
}

}  // namespace

void addServeCommand(CLI::App& app) {
  auto a = std::make_shared<ServeArgs>();
  const server::ServerConfig d;  // the built-in defaults
  CLI::App* cmd =
      app.add_subcommand("serve",
                         "Serve frames of a directory of stores and .vdb files over TCP, and to browsers over HTTP and "
                         "WebSocket with --http (proto/PROTOCOL.md)");
  CLI::Option* config =
      cmd->add_option("--config", a->config,
                      "TOML configuration; options below override it (default: server.toml in the configuration "
                      "directory if there is one: config/ beside build/, PREFIX/share/voxbrick when installed, or "
                      "$VOXBRICK_CONFIG_DIR)")
          ->check(CLI::ExistingFile);
  cmd->add_flag("--no-config", a->noConfig, "read no configuration file: the built-in defaults and the options below")
      ->excludes(config);
  cmd->add_option("--host", a->host, "address to listen on" + configured(d.host, "server.host"));
  cmd->add_option("--port", a->port, "TCP port; 0 picks a free one" + configured(d.port, "server.port"))
      ->check(between(0, 65535));
  cmd->add_option("--port-file", a->portFile, "write the port actually bound to this file");
  cmd->add_option("--http", a->http,
                  "also serve the browser viewer on this HTTP port, with the protocol over a WebSocket on /ws "
                  "(0 picks a free port; default: http.port of the configuration, else none)")
      ->check(between(0, 65535));
  cmd->add_option("--http-bind", a->httpBind,
                  "address the HTTP port listens on (default: as --host, or http.bind of the configuration)");
  cmd->add_option("--http-origin", a->httpOrigins,
                  "an origin (scheme://host[:port]) whose pages may open /ws besides the viewer's own; repeatable "
                  "(default none, or http.origins of the configuration)")
      ->allow_extra_args(false);
  cmd->add_option("--http-token", a->httpToken,
                  "access token /ws must be opened with (?token=...); the viewer's URL, logged at start, carries it "
                  "(default none, or http.token of the configuration)");
  cmd->add_option("--http-port-file", a->httpPortFile, "write the HTTP port actually bound to this file");
  cmd->add_option("--tls-cert", a->tlsCert,
                  "PEM certificate chain (the server's certificate first): both ports speak TLS only, the TCP port "
                  "the protocol and the HTTP port https:// and wss://; read again on SIGHUP (default none, or "
                  "tls.cert of the configuration)");
  cmd->add_option("--tls-key", a->tlsKey,
                  "PEM private key of --tls-cert, not encrypted; read again on SIGHUP (default none, or tls.key of "
                  "the configuration)");
  cmd->add_option("--tls-ca", a->tlsCa,
                  "PEM certificates of the CAs whose client certificates the server asks for and requires, mutual "
                  "TLS (default none, or tls.ca of the configuration)");
  cmd->add_option("--audit-log", a->auditLog,
                  "append the audit trail to this file: a line of JSON per session, token, dataset opened and "
                  "refusal, rotated by size (default none, or audit.path of the configuration)");
  cmd->add_option("--upload-max-mb", a->uploadMaxMB,
                  "take volumes sent by clients whose token may upload (the --http-token, or a [[tokens]] entry with "
                  "upload = true) as new datasets, each of at most this many MiB of voxels; 0: none" +
                      configured(double(d.upload.maxBytes >> 20), "upload.max_bytes (in bytes)"))
      ->check(between(0, 1 << 30, "MiB"));
  cmd->add_option("--datasets", a->datasets,
                  "directory whose subdirectories are stores and whose .vdb files are read live (first float grid, "
                  "bricks of 32)" +
                      configured(d.datasets.string(), "server.datasets"));
  cmd->add_option("--backend", a->backend,
                  "auto, egl or osmesa" + configured(std::string(render::backendName(d.backend)), "server.backend"));
  cmd->add_option("--log-level", a->logLevel,
                  "trace, debug, info, warn, error or off" + configured(d.logLevel, "server.log_level"));
  addMpiOptions(cmd, a->mpi, "under mpirun: rank 0 serves, every rank draws a part of each grid frame");
  cmd->add_option("--render-threads", a->renderThreads,
                  "render threads, each with its own GL context" + configured(d.renderThreads, "server.render_threads"))
      ->check(between(1, 64));
  cmd->add_option("--io-threads", a->ioThreads, "network I/O threads" + configured(d.ioThreads, "server.io_threads"))
      ->check(between(1, 64));
  cmd->add_option("--max-sessions", a->maxSessions,
                  "concurrent sessions" + configured(d.maxSessions, "limits.max_sessions"))
      ->check(between(1, 100000));
  cmd->add_option("--max-image-side", a->maxImageSide,
                  "largest frame side in pixels" + configured(d.maxImageSide, "limits.max_image_side"))
      ->check(between(1, 8192, "pixels"));
  cmd->add_option("--max-render-msamples", a->maxRenderMSamples,
                  "most a Render may cost, in millions of samples (an upper estimate made before drawing)" +
                      configured(d.maxRenderMSamples, "limits.max_render_msamples"))
      ->check(between(1, 1e9, "million samples"));
  cmd->add_option("--max-message-bytes", a->maxMessageBytes,
                  "largest client message body" + configured(d.maxMessageBytes, "limits.max_message_bytes"))
      ->check(between(1024, 64 << 20, "bytes"));
  cmd->add_option(
         "--idle-timeout", a->idleTimeout,
         "seconds without a message before a session is closed" + configured(d.idleTimeoutS, "limits.idle_timeout_s"))
      ->check(between(0.1, 86400, "seconds"));
  cmd->add_option(
         "--read-timeout", a->readTimeout,
         "seconds to complete a message from its first byte" + configured(d.readTimeoutS, "limits.read_timeout_s"))
      ->check(between(0.1, 3600, "seconds"));
  cmd->add_option("--write-timeout", a->writeTimeout,
                  "seconds a client may take to accept a reply (a client that never reads is closed after it)" +
                      configured(d.writeTimeoutS, "limits.write_timeout_s"))
      ->check(between(0.1, 3600, "seconds"));
  cmd->add_option(
         "--hello-timeout", a->helloTimeout,
         "seconds a new connection has to complete its Hello" + configured(d.helloTimeoutS, "limits.hello_timeout_s"))
      ->check(between(0.1, 3600, "seconds"));
  cmd->add_option("--max-pending-connections", a->maxPending,
                  "connections not yet past Hello; one more closes the oldest of them" +
                      configured(d.maxPendingConnections, "limits.max_pending_connections"))
      ->check(between(1, 100000));
  cmd->add_option("--max-connections-per-address", a->maxPerAddress,
                  "connections of one client address (0: no limit; loopback is exempt unless the configuration "
                  "says loopback_exempt = false)" +
                      configured(d.maxConnectionsPerAddress, "limits.max_connections_per_address"))
      ->check(between(0, 100000));
  cmd->add_option("--max-total-output-mb", a->maxTotalOutputMB,
                  "MB of replies not yet read by all clients together; a frame beyond it is answered LimitExceeded" +
                      configured(double(d.maxTotalOutputBytes >> 20), "limits.max_total_output_bytes (in bytes)"))
      ->check(between(1, 1 << 22, "MB"));
  cmd->add_option("--host-cache", a->hostCacheMB,
                  "MB of decoded bricks for all open datasets together (an equal share each)" +
                      configured(d.hostCacheMB, "memory.host_cache_mb"))
      ->check(between(16, 1 << 22, "MB"));
  cmd->add_option("--gpu-budget", a->gpuBudgetMB,
                  "MB of GPU brick atlas for all render threads and datasets together (an equal share per thread)" +
                      configured(d.gpuBudgetMB, "memory.gpu_budget_mb"))
      ->check(between(16, 1 << 22, "MB"));
  cmd->add_option("--video-memory", a->videoMB,
                  "MB of video encoders for all sessions together: past it resting streams' encoders are freed, and a "
                  "moving frame with no room goes as JPEG (0: every moving frame as JPEG)" +
                      configured(d.videoMB, "memory.video_mb"))
      ->check(between(0, 1 << 22, "MB"));
  cmd->add_flag("--no-coalesce", a->noCoalesce,
                "render every request in order instead of only a session's newest (to measure what latest-wins saves)");
  CLI::Option* replay = cmd->add_option("--replay-frames", a->replayFrames,
                  "benchmarks: draw nothing; answer each frame with the frame of DIR (replay.json lists them, each "
                  "with its orbit camera) nearest its camera, so that a benchmark measures everything but drawing "
                  "(docs/server.md)")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--replay-draw-ms", a->replayDrawMs,
                  "benchmarks: with --replay-frames, the time each frame takes, as if drawn")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10000.0))
      ->needs(replay);
  cmd->callback([a] {
    keepFreedMemoryForFrames();
    runServe(*a);
  });
}

}  // namespace voxbrick::cli
