// The server configuration parser: ServerConfig::load and validate.
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "render/core/Backend.h"
#include "server/ServerConfig.h"
#include "support/TestSupport.h"

namespace voxbrick::server {
namespace {

class ServerConfigTest : public ::testing::Test {
 protected:
  test::ScratchDir dir;

  std::filesystem::path write(const std::string& toml) {
    const auto path = dir / "server.toml";
    test::writeFile(path, toml);
    return path;
  }
  /// The message load() throws for `toml`; fails the test if it loads.
  std::string loadError(const std::string& toml) {
    try {
      ServerConfig::load(write(toml));
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    ADD_FAILURE() << "loaded: " << toml;
    return "";
  }
};

#define EXPECT_MENTIONS(text, part) EXPECT_NE((text).find(part), std::string::npos) << (text)

TEST_F(ServerConfigTest, AnEmptyFileGivesTheDefaults) {
  const ServerConfig c = ServerConfig::load(write(""));
  const ServerConfig d;
  EXPECT_EQ(c.host, "127.0.0.1");
  EXPECT_EQ(c.port, 7420);
  EXPECT_EQ(c.backend, render::Backend::Auto);
  EXPECT_EQ(c.datasets, d.datasets);
  EXPECT_EQ(c.renderThreads, d.renderThreads);
  EXPECT_EQ(c.maxSessions, 64);
  EXPECT_EQ(c.maxMessageBytes, 1u << 20);
  EXPECT_EQ(c.maxImageSide, 4096);
  EXPECT_TRUE(c.scheduler.coalesce);
  EXPECT_TRUE(c.encodeAside);
  EXPECT_EQ(c.maxQueuedPerSession(), 1u);
  EXPECT_EQ(c.maxPendingConnections, 16);
  EXPECT_DOUBLE_EQ(c.helloTimeoutS, 5);
  EXPECT_EQ(c.maxConnectionsPerAddress, 32);
  EXPECT_TRUE(c.loopbackExempt);
  EXPECT_EQ(c.pauseReadingBytes, 1u << 20);
  EXPECT_EQ(c.maxTotalOutputBytes, 1ull << 30);
  EXPECT_NO_THROW(d.validate());
}

TEST_F(ServerConfigTest, EveryKeyIsRead) {
  const ServerConfig c = ServerConfig::load(write(R"(
[server]
host = "0.0.0.0"
port = 0
datasets = "stores"
io_threads = 3
render_threads = 4
backend = "osmesa"
log_level = "debug"
coalesce = false
encode_aside = false
[limits]
max_sessions = 5
max_message_bytes = 2048
max_image_side = 512
idle_timeout_s = 1.5
read_timeout_s = 2
write_timeout_s = 3
max_output_bytes = 2097152
max_pending_connections = 4
hello_timeout_s = 0.5
max_connections_per_address = 0
loopback_exempt = false
pause_reading_bytes = 65536
max_total_output_bytes = 8388608
[memory]
host_cache_mb = 32
gpu_budget_mb = 64
video_mb = 96
[scheduler]
interactive_weight = 8
still_weight = 2
batch_weight = 0.5
interactive_fps = 12
encoder_ladder = false
stream_follows_drawing = false
reserved_interactive_threads = 2
batch_max_wait_ms = 500
max_interactive_sessions = 7
min_interactive_fps = 4
share_frames = false
loaded_jpeg_quality = 60
[quotas]
sessions_per_address = 3
frames_per_s_per_address = 20
sessions_per_token = 5
frames_per_s_per_token = 40
loopback_exempt = true
[tls]
cert = "certs/server.pem"
key = "/etc/voxbrick/server.key"
ca = "clients.pem"
[audit]
path = "audit.jsonl"
max_bytes = 65536
keep = 3
[upload]
max_bytes = 1073741824
max_concurrent = 3
[[tokens]]
id = "lab"
sha256 = "0000000000000000000000000000000000000000000000000000000000000000"
datasets = ["lab-*"]
upload = true
)"));
  EXPECT_EQ(c.host, "0.0.0.0");
  EXPECT_EQ(c.port, 0);
  EXPECT_EQ(c.datasets, dir.path() / "stores") << "relative to the configuration file";
  EXPECT_EQ(c.ioThreads, 3);
  EXPECT_EQ(c.renderThreads, 4);
  EXPECT_EQ(c.backend, render::Backend::OsMesa);
  EXPECT_EQ(c.logLevel, "debug");
  EXPECT_FALSE(c.scheduler.coalesce);
  EXPECT_FALSE(c.encodeAside);
  EXPECT_EQ(c.maxQueuedPerSession(), ServerConfig::kMaxQueuedWithoutCoalescing);
  EXPECT_EQ(c.maxSessions, 5);
  EXPECT_EQ(c.maxMessageBytes, 2048u);
  EXPECT_EQ(c.maxImageSide, 512);
  EXPECT_DOUBLE_EQ(c.idleTimeoutS, 1.5);
  EXPECT_DOUBLE_EQ(c.readTimeoutS, 2);
  EXPECT_DOUBLE_EQ(c.writeTimeoutS, 3);
  EXPECT_EQ(c.maxOutputBytes, 2097152u);
  EXPECT_EQ(c.maxPendingConnections, 4);
  EXPECT_DOUBLE_EQ(c.helloTimeoutS, 0.5);
  EXPECT_EQ(c.maxConnectionsPerAddress, 0);
  EXPECT_FALSE(c.loopbackExempt);
  EXPECT_EQ(c.pauseReadingBytes, 65536u);
  EXPECT_EQ(c.maxTotalOutputBytes, 8388608u);
  EXPECT_EQ(c.hostCacheMB, 32);
  EXPECT_EQ(c.gpuBudgetMB, 64);
  EXPECT_EQ(c.videoMB, 96);
  EXPECT_DOUBLE_EQ(c.scheduler.interactiveWeight, 8);
  EXPECT_DOUBLE_EQ(c.scheduler.stillWeight, 2);
  EXPECT_DOUBLE_EQ(c.scheduler.batchWeight, 0.5);
  EXPECT_DOUBLE_EQ(c.scheduler.interactiveFps, 12);
  EXPECT_FALSE(c.scheduler.encoderLadder);
  EXPECT_FALSE(c.scheduler.streamFollowsDrawing);
  EXPECT_EQ(c.scheduler.reservedInteractiveThreads, 2);
  EXPECT_DOUBLE_EQ(c.scheduler.batchMaxWaitMs, 500);
  EXPECT_EQ(c.scheduler.maxInteractiveSessions, 7);
  EXPECT_DOUBLE_EQ(c.scheduler.minInteractiveFps, 4);
  EXPECT_FALSE(c.scheduler.shareFrames);
  EXPECT_EQ(c.scheduler.loadedJpegQuality, 60);
  EXPECT_EQ(c.quotas.sessionsPerAddress, 3);
  EXPECT_DOUBLE_EQ(c.quotas.framesPerSecondPerAddress, 20);
  EXPECT_EQ(c.quotas.sessionsPerToken, 5);
  EXPECT_DOUBLE_EQ(c.quotas.framesPerSecondPerToken, 40);
  EXPECT_TRUE(c.quotas.loopbackExempt);
  EXPECT_EQ(c.tls.cert, dir.path() / "certs/server.pem") << "relative to the configuration file";
  EXPECT_EQ(c.tls.key, "/etc/voxbrick/server.key");
  EXPECT_EQ(c.tls.ca, dir.path() / "clients.pem");
  EXPECT_EQ(c.auditPath, dir.path() / "audit.jsonl");
  EXPECT_EQ(c.auditMaxBytes, 65536u);
  EXPECT_EQ(c.auditKeep, 3);
  EXPECT_EQ(c.upload.maxBytes, 1073741824u);
  EXPECT_EQ(c.upload.maxConcurrent, 3);
  ASSERT_EQ(c.tokens.size(), 1u);
  EXPECT_TRUE(c.tokens[0].upload);
}

TEST_F(ServerConfigTest, APacsIsReadAndChecked) {
  const ServerConfig c = ServerConfig::load(write(R"(
[[pacs]]
id = "ward"
url = "https://pacs.example.org/dicom-web"
auth_file = "pacs.auth"
ca = "/etc/ca.pem"
patient_fields = true
refresh_s = 30
[[pacs]]
id = "lab_2"
url = "http://127.0.0.1:8042/dicom-web"
[pacs_cache]
dir = "cache"
max_mb = 2048
)"));
  ASSERT_EQ(c.pacs.size(), 2u);
  EXPECT_EQ(c.pacs[0].id, "ward");
  EXPECT_EQ(c.pacs[0].url, "https://pacs.example.org/dicom-web");
  EXPECT_EQ(c.pacs[0].authFile, dir.path() / "pacs.auth") << "relative to the configuration file";
  EXPECT_EQ(c.pacs[0].ca, "/etc/ca.pem");
  EXPECT_TRUE(c.pacs[0].patientFields);
  EXPECT_DOUBLE_EQ(c.pacs[0].refreshS, 30);
  EXPECT_FALSE(c.pacs[1].patientFields);
  EXPECT_TRUE(c.pacs[1].authFile.empty());
  EXPECT_DOUBLE_EQ(c.pacs[1].refreshS, 60);
  EXPECT_EQ(c.pacsCache.dir, dir.path() / "cache");
  EXPECT_EQ(c.pacsCache.maxMB, 2048);
  const auto error = [&](const std::string& entry) { return loadError("[[pacs]]\n" + entry); };
  EXPECT_NE(error("id = \"a.b\"\nurl = \"http://h/d\"\n").find("id 'a.b' must be 1 to 64 letters"), std::string::npos);
  EXPECT_NE(error("url = \"http://h/d\"\n").find("pacs[1]: id '' must be"), std::string::npos);
  EXPECT_NE(error("id = \"a\"\nurl = \"dicomweb://h/d\"\n").find("is not http[s]://HOST[:PORT]/PATH"),
            std::string::npos);
  EXPECT_NE(error("id = \"a\"\nurl = \"http://user:pw@h/d\"\n").find("url holds credentials"), std::string::npos);
  EXPECT_NE(error("id = \"a\"\nurl = \"http://h/d?x=1\"\n").find("has a query"), std::string::npos);
  EXPECT_NE(error("id = \"a\"\nurl = \"http://h/d\"\nrefresh_s = 0\n").find("refresh_s"), std::string::npos);
  EXPECT_NE(error("id = \"a\"\nurl = \"http://h/d\"\npassword = \"x\"\n").find("unknown key"), std::string::npos);
  EXPECT_NE(loadError("[[pacs]]\nid = \"a\"\nurl = \"http://h/d\"\n[[pacs]]\nid = \"a\"\nurl = \"http://g/d\"\n")
                .find("given to two PACS"),
            std::string::npos);
  EXPECT_NE(loadError("[pacs_cache]\nmax_mb = 1\n").find("pacs_cache.max_mb"), std::string::npos);
}

TEST_F(ServerConfigTest, UploadsAreOffByDefaultAndTheirValuesAreChecked) {
  const ServerConfig defaults;
  EXPECT_EQ(defaults.upload.maxBytes, 0u);
  EXPECT_EQ(defaults.upload.maxConcurrent, 1);
  EXPECT_NE(loadError("[upload]\nmax_concurrent = 0\n").find("upload.max_concurrent"), std::string::npos);
  EXPECT_NE(loadError("[upload]\nmax_bytes = -1\n").find("upload.max_bytes"), std::string::npos);
  EXPECT_NE(loadError("[upload]\nquota = 1\n").find("unknown key upload.quota"), std::string::npos);
  EXPECT_NE(loadError("[[tokens]]\nid = \"a\"\nsha256 = \"" + std::string(64, '0') + "\"\ndatasets = [\"*\"]\n"
                      "upload = \"yes\"\n")
                .find("upload"),
            std::string::npos);
}

TEST_F(ServerConfigTest, TlsAndAuditValuesAreChecked) {
  const auto error = [&](const std::string& toml) { return loadError(toml); };
  EXPECT_NE(error("[tls]\ncert = \"c.pem\"\n").find("tls.cert is set without tls.key"), std::string::npos);
  EXPECT_NE(error("[tls]\nkey = \"k.pem\"\n").find("tls.key is set without tls.cert"), std::string::npos);
  EXPECT_NE(error("[tls]\nca = \"ca.pem\"\n").find("tls.ca is set without tls.cert"), std::string::npos);
  EXPECT_NE(error("[tls]\npassword = \"x\"\n").find("unknown key tls.password"), std::string::npos);
  EXPECT_NE(error("[audit]\nmax_bytes = 10\n").find("audit.max_bytes"), std::string::npos);
  EXPECT_NE(error("[audit]\nkeep = 5000\n").find("audit.keep"), std::string::npos);
}

TEST_F(ServerConfigTest, SchedulerAndQuotaValuesOutOfRangeOrUnknownAreNamed) {
  const auto error = [&](const std::string& text) {
    try {
      ServerConfig::load(write(text));
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error("[scheduler]\nbatch_weight = 0\n").find("scheduler.batch_weight"), std::string::npos);
  EXPECT_NE(error("[scheduler]\nloaded_jpeg_quality = 101\n").find("scheduler.loaded_jpeg_quality"),
            std::string::npos);
  EXPECT_NE(error("[quotas]\nframes_per_s_per_token = -1\n").find("quotas.frames_per_s_per_token"),
            std::string::npos);
  EXPECT_NE(error("[quotas]\nsessions = 3\n").find("unknown key quotas.sessions"), std::string::npos);
}

TEST_F(ServerConfigTest, TheShippedFileIsValid) {
  const ServerConfig c = ServerConfig::load(std::string(VOXBRICK_SOURCE_DIR) + "/config/server.toml");
  EXPECT_EQ(c.backend, render::Backend::Auto);
  EXPECT_EQ(c.datasets.lexically_normal(), (std::filesystem::path(VOXBRICK_SOURCE_DIR) / "demo").lexically_normal());
}

TEST_F(ServerConfigTest, AWrongTypeNamesTheFileAndTheKey) {
  struct Case {
    const char* section;
    const char* key;
    const char* value;
    const char* expected;
  };
  const Case cases[] = {
      {"server", "host", "1", "must be a string"},
      {"server", "port", "\"7420\"", "must be an integer"},
      {"server", "datasets", "[]", "must be a string"},
      {"server", "io_threads", "1.5", "must be an integer"},
      {"server", "render_threads", "true", "must be an integer"},
      {"server", "backend", "1", "must be a string"},
      {"server", "log_level", "2", "must be a string"},
      {"server", "coalesce", "\"yes\"", "must be true or false"},
      {"server", "encode_aside", "1", "must be true or false"},
      {"limits", "max_sessions", "\"many\"", "must be an integer"},
      {"limits", "max_message_bytes", "1e6", "must be an integer"},
      {"limits", "max_image_side", "{}", "must be an integer"},
      {"limits", "idle_timeout_s", "\"1\"", "must be a number"},
      {"limits", "read_timeout_s", "false", "must be a number"},
      {"limits", "write_timeout_s", "[1]", "must be a number"},
      {"limits", "max_output_bytes", "1.0", "must be an integer"},
      {"limits", "max_pending_connections", "\"16\"", "must be an integer"},
      {"limits", "hello_timeout_s", "true", "must be a number"},
      {"limits", "max_connections_per_address", "-1", "out of range"},
      {"limits", "loopback_exempt", "1", "must be true or false"},
      {"limits", "pause_reading_bytes", "1.5", "must be an integer"},
      {"limits", "max_total_output_bytes", "\"1G\"", "must be an integer"},
      {"memory", "host_cache_mb", "\"1G\"", "must be an integer"},
      {"memory", "gpu_budget_mb", "0.5", "must be an integer"},
      {"memory", "video_mb", "\"4G\"", "must be an integer"},
  };
  for (const Case& c : cases) {
    const std::string message = loadError(std::string("[") + c.section + "]\n" + c.key + " = " + c.value + "\n");
    EXPECT_MENTIONS(message, (dir / "server.toml").string());
    EXPECT_MENTIONS(message, std::string(c.section) + "." + c.key);
    EXPECT_MENTIONS(message, c.expected);
  }
  EXPECT_MENTIONS(loadError("limits = 3\n"), "limits must be a table");
}

TEST_F(ServerConfigTest, UnknownKeysAreRefusedByName) {
  EXPECT_MENTIONS(loadError("[limits]\nmax_sesions = 4\n"), "unknown key limits.max_sesions");
  EXPECT_MENTIONS(loadError("[server]\nthreads = 4\n"), "unknown key server.threads");
  EXPECT_MENTIONS(loadError("[cache]\nsize = 4\n"), "unknown key cache");
  EXPECT_MENTIONS(loadError("port = 4\n"), "unknown key port");
}

TEST_F(ServerConfigTest, ValuesOutOfRangeAreRefusedByName) {
  const std::pair<const char*, const char*> cases[] = {
      {"[server]\nport = 70000\n", "server.port"},
      {"[server]\nport = -1\n", "server.port"},
      {"[server]\nio_threads = 0\n", "server.io_threads"},
      {"[server]\nrender_threads = 65\n", "server.render_threads"},
      {"[server]\nlog_level = \"loud\"\n", "server.log_level"},
      {"[limits]\nmax_sessions = 0\n", "limits.max_sessions"},
      {"[limits]\nmax_message_bytes = 100\n", "limits.max_message_bytes"},
      {"[limits]\nmax_image_side = 100000\n", "limits.max_image_side"},
      {"[limits]\nidle_timeout_s = 0\n", "limits.idle_timeout_s"},
      {"[limits]\nread_timeout_s = -1\n", "limits.read_timeout_s"},
      {"[limits]\nwrite_timeout_s = 1e9\n", "limits.write_timeout_s"},
      {"[limits]\nmax_output_bytes = 1000\n", "limits.max_output_bytes"},
      {"[limits]\nmax_pending_connections = 0\n", "limits.max_pending_connections"},
      {"[limits]\nhello_timeout_s = 0\n", "limits.hello_timeout_s"},
      {"[limits]\nmax_connections_per_address = 1000000\n", "limits.max_connections_per_address"},
      {"[limits]\npause_reading_bytes = 100\n", "limits.pause_reading_bytes"},
      // Pausing must come before the session's own limit drops it.
      {"[limits]\nmax_output_bytes = 2097152\npause_reading_bytes = 4194304\n", "limits.pause_reading_bytes"},
      {"[limits]\nmax_total_output_bytes = 1000\n", "limits.max_total_output_bytes"},
      {"[memory]\nhost_cache_mb = 1\n", "memory.host_cache_mb"},
      {"[memory]\ngpu_budget_mb = 8\n", "memory.gpu_budget_mb"},
      {"[memory]\nvideo_mb = -1\n", "memory.video_mb"},
      // The budget is shared by the render threads: 16 MB cannot be cut into 8 useful shares.
      {"[server]\nrender_threads = 8\n[memory]\ngpu_budget_mb = 16\n", "memory.gpu_budget_mb"},
  };
  for (const auto& [toml, key] : cases) {
    const std::string message = loadError(toml);
    EXPECT_MENTIONS(message, key);
    EXPECT_MENTIONS(message, (dir / "server.toml").string());
  }
  // validate() checks values set in code (the command line's overrides) the same way.
  ServerConfig c;
  c.maxImageSide = 0;
  EXPECT_THROW(c.validate(), std::runtime_error);
  try {
    c.validate();
  } catch (const std::runtime_error& e) {
    EXPECT_MENTIONS(std::string(e.what()), "limits.max_image_side");
  }
}

TEST_F(ServerConfigTest, ABadBackendNameIsRefusedWithTheValue) {
  const std::string message = loadError("[server]\nbackend = \"vulkan\"\n");
  EXPECT_MENTIONS(message, "server.backend");
  EXPECT_MENTIONS(message, "'vulkan'");
  EXPECT_MENTIONS(message, (dir / "server.toml").string());
  EXPECT_EQ(ServerConfig::load(write("[server]\nbackend = \"egl\"\n")).backend, render::Backend::Egl);
  EXPECT_EQ(ServerConfig::parseBackend("auto", "--backend"), render::Backend::Auto);
  try {
    ServerConfig::parseBackend("EGL", "--backend");
    ADD_FAILURE() << "no silent fallback for an unknown name";
  } catch (const std::runtime_error& e) {
    EXPECT_MENTIONS(std::string(e.what()), "--backend = 'EGL'");
  }
}

TEST_F(ServerConfigTest, TheHttpSectionIsReadAndChecked) {
  EXPECT_FALSE(ServerConfig::load(write("")).http);
  EXPECT_FALSE(ServerConfig::load(write("[http]\nport = 0\n")).http) << "port 0: no HTTP";
  const ServerConfig c = ServerConfig::load(write(R"(
[server]
host = "127.0.0.1"
[http]
port = 8080
bind = "0.0.0.0"
origins = ["https://lab.example.org", "http://viewer.example.org:9000"]
token = "a-b.c_d~9"
)"));
  EXPECT_TRUE(c.http);
  EXPECT_EQ(c.httpPort, 8080);
  EXPECT_EQ(c.httpHost(), "0.0.0.0");
  EXPECT_EQ(c.httpOrigins, (std::vector<std::string>{"https://lab.example.org", "http://viewer.example.org:9000"}));
  EXPECT_EQ(c.httpToken, "a-b.c_d~9");
  EXPECT_EQ(ServerConfig::load(write("[http]\nport = 8080\n")).httpHost(), "127.0.0.1") << "bind: as server.host";

  EXPECT_MENTIONS(loadError("[http]\nport = 70000\n"), "http.port");
  EXPECT_MENTIONS(loadError("[http]\norigins = \"https://a.org\"\n"), "http.origins must be an array of strings");
  EXPECT_MENTIONS(loadError("[http]\norigins = [\"a.org\"]\n"), "'a.org' is not an origin");
  EXPECT_MENTIONS(loadError("[http]\norigins = [\"https://a.org/path\"]\n"), "is not an origin");
  EXPECT_MENTIONS(loadError("[http]\ntoken = \"has space\"\n"), "http.token");
  EXPECT_MENTIONS(loadError("[http]\nport = 8080\ncolor = 1\n"), "unknown key http.color");
}

TEST_F(ServerConfigTest, ASyntaxErrorNamesTheFileAndLine) {
  const std::string message = loadError("[server]\nport = 7420\nhost = \n");
  EXPECT_EQ(message.rfind((dir / "server.toml").string() + ":3:", 0), 0u) << message;
  EXPECT_MENTIONS(loadError("[server\n"), (dir / "server.toml").string());
}

/// A number as `serve --help` writes a default: integers without a fraction, others to six digits.
std::string written(double v) {
  char text[64];
  std::snprintf(text, sizeof text, v == std::floor(v) ? "%.0f" : "%.6g", v);
  return text;
}

/// The help entry of `option` in `help` (from its line to the next option's), with runs of white space as one space.
std::string entryOf(const std::string& help, const std::string& option) {
  const size_t at = help.find("\n  " + option + " ");
  if (at == std::string::npos) return "";
  const size_t end = help.find("\n  -", at + 1);
  std::string entry;
  for (char c : help.substr(at + 1, end == std::string::npos ? std::string::npos : end - at - 1))
    if (!std::isspace(static_cast<unsigned char>(c)) || (!entry.empty() && entry.back() != ' '))
      entry += std::isspace(static_cast<unsigned char>(c)) ? ' ' : c;
  return entry;
}

// Each option of `serve` that overrides a key of the configuration says the default the server uses without it, and
// the key: the built-in default, which the shipped config/server.toml (what `serve` reads from a build) holds too.
TEST(ServeHelp, EachOverrideShowsTheDefaultTheServerUsesAndItsKey) {
  const ServerConfig d;
  const ServerConfig shipped = ServerConfig::load(std::filesystem::path(VOXBRICK_SOURCE_DIR) / "config/server.toml");
  const test::CommandResult r = test::runVoxbrick("serve --help");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  struct Row {
    const char* option;
    const char* key;
    std::function<std::string(const ServerConfig&)> value;
  };
  const std::vector<Row> rows = {
      {"--host", "server.host", [](const ServerConfig& c) { return c.host; }},
      {"--port", "server.port", [](const ServerConfig& c) { return written(c.port); }},
      {"--backend", "server.backend",
       [](const ServerConfig& c) { return std::string(render::backendName(c.backend)); }},
      {"--log-level", "server.log_level", [](const ServerConfig& c) { return c.logLevel; }},
      {"--render-threads", "server.render_threads", [](const ServerConfig& c) { return written(c.renderThreads); }},
      {"--io-threads", "server.io_threads", [](const ServerConfig& c) { return written(c.ioThreads); }},
      {"--max-sessions", "limits.max_sessions", [](const ServerConfig& c) { return written(c.maxSessions); }},
      {"--max-image-side", "limits.max_image_side", [](const ServerConfig& c) { return written(c.maxImageSide); }},
      {"--max-render-msamples", "limits.max_render_msamples",
       [](const ServerConfig& c) { return written(c.maxRenderMSamples); }},
      {"--max-message-bytes", "limits.max_message_bytes",
       [](const ServerConfig& c) { return written(c.maxMessageBytes); }},
      {"--idle-timeout", "limits.idle_timeout_s", [](const ServerConfig& c) { return written(c.idleTimeoutS); }},
      {"--read-timeout", "limits.read_timeout_s", [](const ServerConfig& c) { return written(c.readTimeoutS); }},
      {"--write-timeout", "limits.write_timeout_s", [](const ServerConfig& c) { return written(c.writeTimeoutS); }},
      {"--hello-timeout", "limits.hello_timeout_s", [](const ServerConfig& c) { return written(c.helloTimeoutS); }},
      {"--max-pending-connections", "limits.max_pending_connections",
       [](const ServerConfig& c) { return written(c.maxPendingConnections); }},
      {"--max-connections-per-address", "limits.max_connections_per_address",
       [](const ServerConfig& c) { return written(c.maxConnectionsPerAddress); }},
      {"--max-total-output-mb", "limits.max_total_output_bytes (in bytes)",
       [](const ServerConfig& c) { return written(double(c.maxTotalOutputBytes >> 20)); }},
      {"--upload-max-mb", "upload.max_bytes (in bytes)",
       [](const ServerConfig& c) { return written(double(c.upload.maxBytes >> 20)); }},
      {"--host-cache", "memory.host_cache_mb", [](const ServerConfig& c) { return written(double(c.hostCacheMB)); }},
      {"--gpu-budget", "memory.gpu_budget_mb", [](const ServerConfig& c) { return written(double(c.gpuBudgetMB)); }},
      {"--video-memory", "memory.video_mb", [](const ServerConfig& c) { return written(double(c.videoMB)); }},
  };
  for (const Row& row : rows) {
    const std::string entry = entryOf(r.output, row.option);
    ASSERT_FALSE(entry.empty()) << row.option << " is not in serve --help";
    EXPECT_NE(entry.find("(default " + row.value(d) + ", or " + row.key + " of the configuration)"), std::string::npos)
        << entry;
    EXPECT_EQ(row.value(shipped), row.value(d)) << row.key << " in config/server.toml";
  }
  // The datasets directory: the built-in "demo", the shipped file's "../demo" beside config/ (the source tree's).
  EXPECT_NE(entryOf(r.output, "--datasets").find("(default " + d.datasets.string() + ", or server.datasets"),
            std::string::npos);
  EXPECT_EQ(std::filesystem::weakly_canonical(shipped.datasets),
            std::filesystem::weakly_canonical(std::filesystem::path(VOXBRICK_SOURCE_DIR) / d.datasets));
}

}  // namespace
}  // namespace voxbrick::server
