// The audit trail: its lines (JSON, UTC time, client, transport, the token's id and never its secret), rotation by
// size, and, with the real `voxbrick serve` over TLS with tokens, one line per session, token, dataset opened and
// refusal (a wrong token, a dataset outside the token, a refused upgrade, a failed TLS handshake, a refused connection).
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "RawSocket.h"
#include "ServerProcess.h"
#include "TestCerts.h"
#include "WebClient.h"
#include "client/Client.h"
#include "server/AccessTokens.h"
#include "server/AuditLog.h"
#include "support/TestSupport.h"

namespace voxbrick::audit_tests {
namespace {

using nlohmann::json;
using server::AuditEvent;
using server::AuditLog;
using namespace std::chrono_literals;

std::vector<json> linesOf(const std::filesystem::path& path) {
  std::vector<json> out;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) out.push_back(json::parse(line));
  return out;
}

TEST(AuditLog, ALineIsOneJsonObjectInUtcWithoutASecret) {
  // 2026-12-04 17:00:41.462 UTC.
  const auto when = AuditLog::Clock::time_point(std::chrono::milliseconds(1796403641462LL));
  const std::string line = AuditLog::line({"dataset", "10.1.2.3:40000", "tls", "radiology", "mri", ""}, when);
  EXPECT_EQ(line,
            R"({"time":"2026-12-04T17:00:41.462Z","event":"dataset","client":"10.1.2.3:40000","transport":"tls",)"
            R"("token":"radiology","dataset":"mri"})"
            "\n");
  EXPECT_EQ(AuditLog::line({"refused", "[::1]:5", "ws", "", "", "wrong access token"}, when),
            R"({"time":"2026-12-04T17:00:41.462Z","event":"refused","client":"[::1]:5","transport":"ws",)"
            R"("token":null,"reason":"wrong access token"})"
            "\n");
  // A name a client sent that is not UTF-8 still makes a line of valid JSON.
  EXPECT_NO_THROW(json::parse(AuditLog::line({"refused", "a", "tcp", "", "\xC0\xAF", "no such dataset"}, when)));
}

TEST(AuditLog, TheFileIsRotatedBySizeAndKeepsItsNewestFiles) {
  test::ScratchDir dir;
  const auto path = dir / "audit.log";
  {
    AuditLog log(path, 4096, 2);
    EXPECT_TRUE(log.enabled());
    for (int i = 0; i < 100; ++i)
      log.record({"session", "10.0.0.1:" + std::to_string(1000 + i), "tcp", "", "", ""});
  }
  struct stat s {};
  ASSERT_EQ(::stat(path.c_str(), &s), 0);
  EXPECT_EQ(s.st_mode & 0777, 0600u) << "the trail is its owner's only";
  EXPECT_LE(std::filesystem::file_size(path), 4096u);
  EXPECT_TRUE(std::filesystem::exists(dir / "audit.log.1"));
  EXPECT_TRUE(std::filesystem::exists(dir / "audit.log.2"));
  EXPECT_FALSE(std::filesystem::exists(dir / "audit.log.3")) << "keep = 2";
  // The newest lines are in the file, the ones before them in .1, and none is cut.
  const auto current = linesOf(path), previous = linesOf(dir / "audit.log.1");
  ASSERT_FALSE(current.empty());
  EXPECT_EQ(current.back()["client"], "10.0.0.1:1099");
  EXPECT_EQ(std::stoi(previous.back()["client"].get<std::string>().substr(9)) + 1,
            std::stoi(current.front()["client"].get<std::string>().substr(9)));
  // Appending goes on after a restart.
  AuditLog again(path, 4096, 2);
  again.record({"session", "10.0.0.1:2000", "tcp", "", "", ""});
  EXPECT_EQ(linesOf(path).back()["client"], "10.0.0.1:2000");
  EXPECT_THROW(AuditLog(dir / "missing" / "audit.log", 4096, 2), std::runtime_error);
  AuditLog none;
  EXPECT_FALSE(none.enabled());
  none.record({"session", "x", "tcp", "", "", ""});
}

class AuditServerTest : public test::SparseDatasetSuite {};

TEST_F(AuditServerTest, EverySessionTokenDatasetAndRefusalIsALine) {
  const test::TestCerts certs = test::TestCerts::make(scratch() / "audit-certs");
  const std::filesystem::path dir = scratch() / "audit-datasets";
  std::filesystem::create_directories(dir);
  for (const char* name : {"open-1", "closed"})
    std::filesystem::copy(std::filesystem::path(datasets()) / "sparse", dir / name,
                          std::filesystem::copy_options::recursive);
  const std::string secret = "open-9f8e7d6c5b4a39281706f5e4d3c2b1a0", http = "web-Token_9";
  const auto audit = scratch() / "trail" / "audit.jsonl";
  std::filesystem::create_directories(audit.parent_path());
  const auto config = scratch() / "audit.toml";
  std::ofstream(config) << "[http]\ntoken = \"" << http << "\"\n\n[audit]\npath = \"trail/audit.jsonl\"\n\n"
                        << "[[tokens]]\nid = \"opener\"\nsha256 = \"" << server::AccessTokens::sha256Hex(secret)
                        << "\"\ndatasets = [\"open-*\"]\n";
  test::ServerProcess server("--config " + config.string() + " --datasets " + dir.string() +
                                 " --render-threads 1 --http 0 --tls-cert " +
                                 certs.serverCert.string() + " --tls-key " + certs.serverKey.string(),
                             scratch());
  client::TlsOptions tls;
  tls.enabled = true;
  tls.caFile = certs.caCert.string();
  {
    client::Client c("127.0.0.1", server.port(), 30s, tls);
    c.hello();
    EXPECT_EQ(c.authenticate(secret), "opener");
    c.openDataset("open-1");
    c.render(R"({"size": [32, 32], "transfer_function": "sparse"})");
    EXPECT_THROW(c.openDataset("closed"), client::ServerError);
    c.goodbye();
  }
  {
    client::Client wrong("127.0.0.1", server.port(), 30s, tls);
    wrong.hello();
    EXPECT_THROW(wrong.authenticate("guess"), client::ServerError);
  }
  {
    test::WebSocketClient browser(server.httpPort(), "/ws?token=" + http, "", 30s, certs.caCert.string());
    browser.hello();
    browser.openDataset("closed");
  }
  EXPECT_THROW(test::WebSocketClient(server.httpPort(), "/ws?token=nope", "", 30s, certs.caCert.string()),
               test::UpgradeRefused);
  // A handshake in TLS 1.1.
  test::runShell("echo | openssl s_client -connect 127.0.0.1:" + std::to_string(server.port()) +
                 " -tls1_1 -cipher DEFAULT@SECLEVEL=0 > /dev/null 2>&1");
  std::this_thread::sleep_for(300ms);
  const auto lines = linesOf(audit);
  ASSERT_FALSE(lines.empty());
  std::vector<std::string> seen;
  for (const json& line : lines) {
    // Every line has its time in UTC and says who and how.
    EXPECT_TRUE(line["time"].get<std::string>().ends_with("Z")) << line;
    EXPECT_TRUE(line["client"].get<std::string>().starts_with("127.0.0.1:")) << line;
    const std::string event = line["event"];
    seen.push_back(event + " " + line["transport"].get<std::string>() + " " +
                   (line["token"].is_null() ? "-" : line["token"].get<std::string>()) + " " +
                   line.value("dataset", "") + " " + line.value("reason", ""));
  }
  const auto has = [&](const std::string& start) {
    return std::any_of(seen.begin(), seen.end(), [&](const std::string& s) { return s.starts_with(start); });
  };
  EXPECT_TRUE(has("session tls - ")) << testing::PrintToString(seen);
  EXPECT_TRUE(has("token tls opener ")) << testing::PrintToString(seen);
  EXPECT_TRUE(has("dataset tls opener open-1 ")) << testing::PrintToString(seen);
  EXPECT_TRUE(has("refused tls opener closed not among the datasets of the session's token"))
      << testing::PrintToString(seen);
  EXPECT_TRUE(has("refused tls -  wrong access token")) << testing::PrintToString(seen);
  EXPECT_TRUE(has("session wss http.token ")) << testing::PrintToString(seen);
  EXPECT_TRUE(has("dataset wss http.token closed ")) << testing::PrintToString(seen);
  EXPECT_TRUE(has("refused wss -  WebSocket upgrade: wrong access token")) << testing::PrintToString(seen);
  EXPECT_TRUE(has("refused tls -  TLS handshake: unsupported protocol")) << testing::PrintToString(seen);
  // Never a secret, never a frame: short lines only.
  const std::vector<char> bytes = test::readFile(audit);
  const std::string text(bytes.begin(), bytes.end());
  for (const std::string& s : {secret, http, std::string("guess"), std::string("nope")})
    EXPECT_EQ(text.find(s), std::string::npos) << s;
  for (const json& line : lines) EXPECT_LT(line.dump().size(), 400u);
}

TEST_F(AuditServerTest, AConnectionRefusedOnConnectIsALine) {
  const auto audit = scratch() / "refusals.jsonl";
  const auto config = scratch() / "refusals.toml";
  std::ofstream(config) << "[limits]\nmax_connections_per_address = 1\nloopback_exempt = false\n";
  test::ServerProcess server("--config " + config.string() + " --datasets " + datasets() +
                                 " --render-threads 1 --audit-log " + audit.string(),
                             scratch());
  client::Client first("127.0.0.1", server.port(), 30s);
  first.hello();
  test::RawSocket second(server.port());
  EXPECT_TRUE(second.waitClosed(5s));
  std::this_thread::sleep_for(200ms);
  const auto lines = linesOf(audit);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0]["event"], "session");
  EXPECT_EQ(lines[0]["transport"], "tcp");
  EXPECT_EQ(lines[1]["event"], "refused");
  EXPECT_EQ(lines[1]["reason"], "on connect: too many connections from 127.0.0.1 (limit 1)");
}

}  // namespace
}  // namespace voxbrick::audit_tests
