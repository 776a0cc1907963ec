// TOML configuration through toml++: every key is known, typed and range-checked.
#include "server/ServerConfig.h"

#include <algorithm>
#include <cctype>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include <toml++/toml.h>

#include "common/EnumNames.h"
#include "render/core/RenderErrors.h"
#include "server/WebGate.h"

namespace voxbrick::server {
namespace {

[[noreturn]] void fail(const std::string& what) { throw std::runtime_error(what); }

/// One table of the file. It reads typed keys and remembers them, so anything else the table holds is an unknown
/// key: the list of known keys is the list of reads.
class Section {
 public:
  Section(const toml::table* table, std::string name, std::string file)
      : mTable(table), mName(std::move(name)), mFile(std::move(file)) {}

  /// The sub-table `key` (absent: an empty section).
  Section table(const char* key) {
    mKnown.insert(key);
    const toml::node* node = mTable ? mTable->get(key) : nullptr;
    if (node && !node->is_table()) fail(mFile + ": " + key + " must be a table");
    return Section(node ? node->as_table() : nullptr, key, mFile);
  }

  /// Reads `key` into `out` if present; returns whether it was.
  template <typename T>
  bool read(const char* key, T& out) {
    mKnown.insert(key);
    const toml::node* node = mTable ? mTable->get(key) : nullptr;
    if (!node) return false;
    const std::string name = mFile + ": " + mName + "." + key;
    if constexpr (std::is_same_v<T, bool>) {
      if (!node->is_boolean()) fail(name + " must be true or false");
      out = node->as_boolean()->get();
    } else if constexpr (std::is_same_v<T, std::string> || std::is_same_v<T, std::filesystem::path>) {
      if (!node->is_string()) fail(name + " must be a string");
      out = node->as_string()->get();
    } else if constexpr (std::is_same_v<T, double>) {
      if (!node->is_number()) fail(name + " must be a number");
      out = node->value<double>().value();
    } else {
      if (!node->is_integer()) fail(name + " must be an integer");
      const int64_t v = node->as_integer()->get();
      if (v < 0 || uint64_t(v) > uint64_t(std::numeric_limits<T>::max()))
        fail(name + " = " + std::to_string(v) + " is out of range");
      out = T(v);
    }
    return true;
  }

  /// Reads `key`, an array of strings, into `out` if present; returns whether it was.
  bool readStrings(const char* key, std::vector<std::string>& out) {
    mKnown.insert(key);
    const toml::node* node = mTable ? mTable->get(key) : nullptr;
    if (!node) return false;
    const std::string name = mFile + ": " + mName + "." + key;
    if (!node->is_array()) fail(name + " must be an array of strings");
    out.clear();
    for (const toml::node& item : *node->as_array()) {
      if (!item.is_string()) fail(name + " must be an array of strings");
      out.push_back(item.as_string()->get());
    }
    return true;
  }

  /// The tables of `key`, an array of tables ([[key]] in the file); each is named KEY[N] (from 1) in errors.
  std::vector<Section> arrayOfTables(const char* key) {
    mKnown.insert(key);
    std::vector<Section> out;
    const toml::node* node = mTable ? mTable->get(key) : nullptr;
    if (!node) return out;
    const toml::array* array = node->as_array();
    if (!array || !array->is_array_of_tables())
      fail(mFile + ": " + key + " must be an array of tables ([[" + key + "]] sections)");
    for (size_t i = 0; i < array->size(); ++i)
      out.emplace_back(array->get(i)->as_table(), std::string(key) + "[" + std::to_string(i + 1) + "]", mFile);
    return out;
  }

  /// Throws naming the first key no read() or table() asked for.
  void rejectUnknown() const {
    if (!mTable) return;
    for (const auto& [key, node] : *mTable)
      if (!mKnown.count(std::string(key.str())))
        fail(mFile + ": unknown key " + (mName.empty() ? "" : mName + ".") + std::string(key.str()));
  }

 private:
  const toml::table* mTable;
  std::string mName, mFile;
  std::set<std::string> mKnown;
};

}  // namespace

ServerConfig ServerConfig::load(const std::filesystem::path& path) {
  const std::string file = path.string();
  toml::table root;
  try {
    root = toml::parse_file(file);
  } catch (const toml::parse_error& e) {
    fail(file + ":" + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
  ServerConfig c;
  Section top(&root, "", file);
  Section server = top.table("server");
  server.read("host", c.host);
  server.read("port", c.port);
  // A relative dataset directory is relative to the configuration file.
  if (server.read("datasets", c.datasets) && c.datasets.is_relative()) c.datasets = path.parent_path() / c.datasets;
  server.read("io_threads", c.ioThreads);
  server.read("encode_threads", c.encodeThreads);
  server.read("encode_aside", c.encodeAside);
  server.read("render_threads", c.renderThreads);
  if (std::string backend; server.read("backend", backend))
    c.backend = parseBackend(backend, file + ": server.backend");
  server.read("log_level", c.logLevel);
  server.read("coalesce", c.scheduler.coalesce);
  Section limits = top.table("limits");
  limits.read("max_sessions", c.maxSessions);
  limits.read("max_message_bytes", c.maxMessageBytes);
  limits.read("max_image_side", c.maxImageSide);
  limits.read("idle_timeout_s", c.idleTimeoutS);
  limits.read("read_timeout_s", c.readTimeoutS);
  limits.read("write_timeout_s", c.writeTimeoutS);
  limits.read("max_output_bytes", c.maxOutputBytes);
  limits.read("max_render_msamples", c.maxRenderMSamples);
  limits.read("max_pending_connections", c.maxPendingConnections);
  limits.read("hello_timeout_s", c.helloTimeoutS);
  limits.read("max_connections_per_address", c.maxConnectionsPerAddress);
  limits.read("loopback_exempt", c.loopbackExempt);
  limits.read("pause_reading_bytes", c.pauseReadingBytes);
  limits.read("max_total_output_bytes", c.maxTotalOutputBytes);
  Section http = top.table("http");
  if (http.read("port", c.httpPort)) c.http = c.httpPort > 0;  // 0: no HTTP listener
  http.read("bind", c.httpBind);
  http.readStrings("origins", c.httpOrigins);
  http.read("token", c.httpToken);
  std::vector<Section> tokens = top.arrayOfTables("tokens");
  for (Section& token : tokens) {
    TokenConfig t;
    token.read("id", t.id);
    token.read("sha256", t.sha256);
    token.readStrings("datasets", t.datasets);
    if (int sessions = 0; token.read("sessions", sessions)) t.sessions = sessions;
    if (double frames = 0; token.read("frames_per_s", frames)) t.framesPerSecond = frames;
    token.read("upload", t.upload);
    token.rejectUnknown();
    c.tokens.push_back(std::move(t));
  }
  Section access = top.table("access");
  if (std::vector<std::string> anonymous; access.readStrings("anonymous", anonymous)) c.anonymousDatasets = anonymous;
  Section tls = top.table("tls");
  // Relative files are relative to the configuration file, as the datasets directory is.
  const auto beside = [&](std::filesystem::path& p) {
    if (!p.empty() && p.is_relative()) p = path.parent_path() / p;
  };
  if (tls.read("cert", c.tls.cert)) beside(c.tls.cert);
  if (tls.read("key", c.tls.key)) beside(c.tls.key);
  if (tls.read("ca", c.tls.ca)) beside(c.tls.ca);
  Section audit = top.table("audit");
  if (audit.read("path", c.auditPath)) beside(c.auditPath);
  audit.read("max_bytes", c.auditMaxBytes);
  audit.read("keep", c.auditKeep);
  for (Section& entry : top.arrayOfTables("pacs")) {
    PacsConfig p;
    entry.read("id", p.id);
    entry.read("url", p.url);
    if (entry.read("auth_file", p.authFile)) beside(p.authFile);
    if (entry.read("ca", p.ca)) beside(p.ca);
    entry.read("patient_fields", p.patientFields);
    entry.read("refresh_s", p.refreshS);
    entry.rejectUnknown();
    c.pacs.push_back(std::move(p));
  }
  Section pacsCache = top.table("pacs_cache");
  if (pacsCache.read("dir", c.pacsCache.dir)) beside(c.pacsCache.dir);
  pacsCache.read("max_mb", c.pacsCache.maxMB);
  Section upload = top.table("upload");
  upload.read("max_bytes", c.upload.maxBytes);
  upload.read("max_concurrent", c.upload.maxConcurrent);
  Section memory = top.table("memory");
  memory.read("host_cache_mb", c.hostCacheMB);
  memory.read("gpu_budget_mb", c.gpuBudgetMB);
  memory.read("video_mb", c.videoMB);
  Section scheduler = top.table("scheduler");
  SchedulerConfig& sc = c.scheduler;
  scheduler.read("interactive_weight", sc.interactiveWeight);
  scheduler.read("still_weight", sc.stillWeight);
  scheduler.read("batch_weight", sc.batchWeight);
  scheduler.read("interactive_fps", sc.interactiveFps);
  scheduler.read("encoder_ladder", sc.encoderLadder);
  scheduler.read("stream_follows_drawing", sc.streamFollowsDrawing);
  scheduler.read("reserved_interactive_threads", sc.reservedInteractiveThreads);
  scheduler.read("batch_max_wait_ms", sc.batchMaxWaitMs);
  scheduler.read("max_interactive_sessions", sc.maxInteractiveSessions);
  scheduler.read("busy_at_hello", sc.busyAtHello);
  scheduler.read("interactive_turn_s", sc.interactiveTurnS);
  scheduler.read("min_interactive_fps", sc.minInteractiveFps);
  scheduler.read("cold_interactive_sessions_per_thread", sc.coldInteractiveSessionsPerThread);
  scheduler.read("share_frames", sc.shareFrames);
  scheduler.read("loaded_jpeg_quality", sc.loadedJpegQuality);
  Section quotas = top.table("quotas");
  quotas.read("sessions_per_address", c.quotas.sessionsPerAddress);
  quotas.read("frames_per_s_per_address", c.quotas.framesPerSecondPerAddress);
  quotas.read("sessions_per_token", c.quotas.sessionsPerToken);
  quotas.read("frames_per_s_per_token", c.quotas.framesPerSecondPerToken);
  quotas.read("loopback_exempt", c.quotas.loopbackExempt);
  for (const Section* section : {&top, &server, &limits, &memory, &http, &access, &tls, &audit, &upload, &pacsCache, &scheduler, &quotas})
    section->rejectUnknown();
  try {
    c.validate();
  } catch (const std::exception& e) {
    fail(file + ": " + e.what());
  }
  return c;
}

void ServerConfig::validate() const {
  auto range = [](const std::string& name, double v, double lo, double hi) {
    if (!(v >= lo && v <= hi))
      fail(name + " = " + std::to_string(v) + " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  };
  range("server.port", port, 0, 65535);
  range("server.io_threads", ioThreads, 1, 64);
  range("server.encode_threads", encodeThreads, 1, 64);
  range("server.render_threads", renderThreads, 1, 64);
  static const std::set<std::string> levels = {"trace", "debug", "info", "warn", "error", "off"};
  if (!levels.count(logLevel)) fail("server.log_level = '" + logLevel + "' is not a log level");
  range("limits.max_sessions", maxSessions, 1, 100000);
  range("limits.max_message_bytes", maxMessageBytes, 1024, 64 << 20);
  range("limits.max_image_side", maxImageSide, 1, 8192);
  range("limits.idle_timeout_s", idleTimeoutS, 0.1, 86400);
  range("limits.read_timeout_s", readTimeoutS, 0.1, 3600);
  range("limits.write_timeout_s", writeTimeoutS, 0.1, 3600);
  range("limits.max_output_bytes", double(maxOutputBytes), 1 << 20, double(uint64_t(1) << 40));
  range("limits.max_render_msamples", maxRenderMSamples, 1, 1e9);
  range("limits.max_pending_connections", maxPendingConnections, 1, 100000);
  range("limits.hello_timeout_s", helloTimeoutS, 0.1, 3600);
  range("limits.max_connections_per_address", maxConnectionsPerAddress, 0, 100000);
  // Below max_output_bytes, or a session would be dropped before it is ever paused.
  range("limits.pause_reading_bytes", double(pauseReadingBytes), 4096, double(maxOutputBytes));
  range("limits.max_total_output_bytes", double(maxTotalOutputBytes), 1 << 20, double(uint64_t(1) << 42));
  range("http.port", httpPort, 0, 65535);
  for (const std::string& origin : httpOrigins)
    if (!WebGate::parseOrigin(origin))
      fail("http.origins: '" + origin + "' is not an origin (scheme://host or scheme://host:port, e.g. " +
           "http://viewer.example.org:8080)");
  if (!httpToken.empty() && !WebGate::validToken(httpToken))
    fail("http.token must be letters, digits and - . _ ~ only (it travels in a URL)");
  validateTokens();
  if (tls.cert.empty() != tls.key.empty())
    fail(tls.cert.empty() ? "tls.key is set without tls.cert: give both (--tls-cert and --tls-key)"
                          : "tls.cert is set without tls.key: give both (--tls-cert and --tls-key)");
  if (!tls.ca.empty() && tls.cert.empty()) fail("tls.ca is set without tls.cert and tls.key");
  range("audit.max_bytes", double(auditMaxBytes), 4096, double(uint64_t(1) << 40));
  range("audit.keep", auditKeep, 0, 1000);
  range("upload.max_bytes", double(upload.maxBytes), 0, double(uint64_t(1) << 50));
  range("upload.max_concurrent", upload.maxConcurrent, 1, 64);
  range("pacs_cache.max_mb", double(pacsCache.maxMB), 16, double(int64_t(1) << 30));
  std::set<std::string> pacsIds;
  for (size_t i = 0; i < pacs.size(); ++i) {
    const PacsConfig& p = pacs[i];
    const std::string where = "pacs[" + std::to_string(i + 1) + "]" + (p.id.empty() ? "" : " ('" + p.id + "')");
    const bool plainId = !p.id.empty() && p.id.size() <= 64 && std::all_of(p.id.begin(), p.id.end(), [](char ch) {
      return std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_';
    });
    if (!plainId) fail(where + ": id '" + p.id + "' must be 1 to 64 letters, digits, '-' or '_'");
    if (!pacsIds.insert(p.id).second) fail(where + ": id '" + p.id + "' is given to two PACS");
    const bool isHttp = p.url.starts_with("http://") || p.url.starts_with("https://");
    const std::string rest = isHttp ? p.url.substr(p.url.find("//") + 2) : "";
    if (!isHttp || rest.empty() || rest.front() == '/')
      fail(where + ": url '" + p.url + "' is not http[s]://HOST[:PORT]/PATH, the PACS' DICOMweb root");
    if (rest.substr(0, rest.find('/')).find('@') != std::string::npos)
      fail(where + ": url holds credentials: give them in auth_file, never in the URL");
    if (p.url.find_first_of("?# ") != std::string::npos) fail(where + ": url '" + p.url + "' has a query or a space");
    range(where + ".refresh_s", p.refreshS, 1, 86400);
  }
  range("scheduler.interactive_weight", scheduler.interactiveWeight, 0.01, 1e6);
  range("scheduler.still_weight", scheduler.stillWeight, 0.01, 1e6);
  range("scheduler.batch_weight", scheduler.batchWeight, 0.01, 1e6);
  range("scheduler.interactive_fps", scheduler.interactiveFps, 0.1, 1000);
  range("scheduler.reserved_interactive_threads", scheduler.reservedInteractiveThreads, 0, 64);
  range("scheduler.batch_max_wait_ms", scheduler.batchMaxWaitMs, 1, 86400e3);
  range("scheduler.max_interactive_sessions", scheduler.maxInteractiveSessions, 0, 100000);
  range("scheduler.min_interactive_fps", scheduler.minInteractiveFps, 0.1, 1000);
  range("scheduler.interactive_turn_s", scheduler.interactiveTurnS, 0, 86400);
  range("scheduler.cold_interactive_sessions_per_thread", scheduler.coldInteractiveSessionsPerThread, 0, 100000);
  range("scheduler.loaded_jpeg_quality", scheduler.loadedJpegQuality, 1, 100);
  range("quotas.sessions_per_address", quotas.sessionsPerAddress, 0, 100000);
  range("quotas.frames_per_s_per_address", quotas.framesPerSecondPerAddress, 0, 1e6);
  range("quotas.sessions_per_token", quotas.sessionsPerToken, 0, 100000);
  range("quotas.frames_per_s_per_token", quotas.framesPerSecondPerToken, 0, 1e6);
  range("memory.host_cache_mb", double(hostCacheMB), 16, 1 << 22);
  range("memory.gpu_budget_mb", double(gpuBudgetMB), 16, 1 << 22);
  range("memory.video_mb", double(videoMB), 0, 1 << 22);
  if (gpuBudgetMB < 4 * int64_t(renderThreads))
    fail("memory.gpu_budget_mb = " + std::to_string(gpuBudgetMB) + " leaves less than 4 MB to each of the " +
         std::to_string(renderThreads) + " render threads");
}

namespace {

bool nameCharacter(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_' || c == '.';
}

/// Throws naming `where` unless each of `patterns` is a dataset name or a glob pattern of one.
void checkPatterns(const std::string& where, const std::vector<std::string>& patterns) {
  for (const std::string& pattern : patterns)
    if (pattern.empty() || !std::all_of(pattern.begin(), pattern.end(), [](char c) {
          return nameCharacter(c) || c == '*' || c == '?' || c == '[' || c == ']' || c == '!' || c == '^';
        }))
      fail(where + ": '" + pattern + "' is not a dataset name or pattern (letters, digits, . - _ and the glob " +
           "characters * ? [ ])");
}

}  // namespace

void ServerConfig::validateTokens() const {
  std::set<std::string> ids;
  std::map<std::string, std::string> hashes;  // lower-case hash -> id
  for (size_t i = 0; i < tokens.size(); ++i) {
    const TokenConfig& t = tokens[i];
    const std::string where = "tokens[" + std::to_string(i + 1) + "]" + (t.id.empty() ? "" : " ('" + t.id + "')");
    if (t.id.empty()) fail(where + ": id is missing");
    if (t.id.size() > 64 || !std::all_of(t.id.begin(), t.id.end(), nameCharacter))
      fail(where + ": id must be at most 64 letters, digits, '.', '-' or '_'");
    if (t.id == "http.token") fail(where + ": the id http.token is the single token of [http]");
    if (!ids.insert(t.id).second) fail(where + ": id '" + t.id + "' is given to two tokens");
    if (t.sha256.size() != 64 || !std::all_of(t.sha256.begin(), t.sha256.end(),
                                              [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); }))
      fail(where +
           ": sha256 must be the 64 hex digits of the SHA-256 of the token's secret (`voxbrick token` "
           "makes a secret and its hash)");
    std::string lower = t.sha256;
    for (char& c : lower) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (const auto [it, fresh] = hashes.emplace(lower, t.id); !fresh)
      fail(where + ": its sha256 is that of '" + it->second + "' too: one secret, two tokens");
    if (t.datasets.empty())
      fail(where + ": datasets is missing: the names or patterns it may open, [\"*\"] for every dataset");
    checkPatterns(where + ".datasets", t.datasets);
    if (t.sessions && (*t.sessions < 0 || *t.sessions > 100000))
      fail(where + ": sessions = " + std::to_string(*t.sessions) + " is outside [0, 100000]");
    if (t.framesPerSecond && !(*t.framesPerSecond >= 0 && *t.framesPerSecond <= 1e6))
      fail(where + ": frames_per_s = " + std::to_string(*t.framesPerSecond) + " is outside [0, 1000000]");
  }
  if (anonymousDatasets) checkPatterns("access.anonymous", *anonymousDatasets);
}

render::Backend ServerConfig::parseBackend(const std::string& text, const std::string& what) {
  try {
    return render::parseBackend(text);
  } catch (const render::RenderInputError&) {
    fail(what + " = '" + text + "' must be " + common::enumNamesText<render::Backend>());
  }
}

}  // namespace voxbrick::server
