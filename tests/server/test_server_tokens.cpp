// Access scoped to datasets on the real `voxbrick serve`: tokens from server.toml over TCP (Authenticate, protocol
// version 5, over TLS) and WebSocket (?token=), the listing filtered, a dataset outside a token refused as a missing
// one, sessions without a token (older clients) held to access.anonymous, the single http.token still opening
// everything, a token's own quota, /metrics for tokens that see every dataset only, and no secret in the log.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "ServerProcess.h"
#include "TestCerts.h"
#include "WebClient.h"
#include "client/Client.h"
#include "server/AccessTokens.h"
#include "support/TestSupport.h"

namespace voxbrick::token_server_tests {
namespace {

using client::Client;
using client::ServerError;
using test::ServerProcess;
using namespace std::chrono_literals;

const std::string kAlpha = "alpha-3d1f9c0e7b2a4d6f8e0c1b3a5d7f9e2c", kAll = "all-6b8d0f2a4c6e8a0b2d4f6a8c0e2b4d6f",
                  kTeam = "team-0a1b2c3d4e5f60718293a4b5c6d7e8f9", kHttp = "http-Token_1";

/// A server over alpha-1, alpha-2 and beta (copies of one sparse store) with three tokens: "alpha" (alpha-*),
/// "all" (*), "team" (beta, one session at a time), and the single http.token.
class TokenServerTest : public test::SparseDatasetSuite {
 protected:
  static void SetUpTestSuite() {
    SparseDatasetSuite::SetUpTestSuite();
    const auto dir = scratch() / "scoped";
    std::filesystem::create_directories(dir);
    for (const char* name : {"alpha-1", "alpha-2", "beta"})
      std::filesystem::copy(std::filesystem::path(datasets()) / "sparse", dir / name,
                            std::filesystem::copy_options::recursive);
  }
  static std::filesystem::path writeConfig(const std::string& extra = "") {
    const auto path = scratch() / "tokens.toml";
    std::ofstream(path) << "[http]\ntoken = \"" << kHttp << "\"\n\n"
                        << extra << "[[tokens]]\nid = \"alpha\"\nsha256 = \"" << server::AccessTokens::sha256Hex(kAlpha)
                        << "\"\ndatasets = [\"alpha-*\"]\n\n[[tokens]]\nid = \"all\"\nsha256 = \""
                        << server::AccessTokens::sha256Hex(kAll) << "\"\ndatasets = [\"*\"]\n\n[[tokens]]\nid = "
                        << "\"team\"\nsha256 = \"" << server::AccessTokens::sha256Hex(kTeam)
                        << "\"\ndatasets = [\"beta\"]\nsessions = 1\n";
    return path;
  }
  static std::unique_ptr<ServerProcess> start(const std::string& extra = "", const std::string& args = "") {
    return std::make_unique<ServerProcess>("--config " + writeConfig(extra).string() + " --datasets " +
                                               (scratch() / "scoped").string() + " --render-threads 1 --http 0 " + args,
                                           scratch());
  }
  /// A TCP session that presented `token`.
  static std::unique_ptr<Client> session(const ServerProcess& server, const std::string& token) {
    auto c = std::make_unique<Client>("127.0.0.1", server.port(), 30s);
    c->hello("token-test");
    c->authenticate(token);
    return c;
  }
  static ServerError refusal(const std::function<void()>& call) {
    try {
      call();
    } catch (const ServerError& e) {
      return e;
    }
    ADD_FAILURE() << "no refusal";
    return ServerError(proto::ErrorCode::Internal, "none");
  }
};

const char* kTokenScene = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [48, 40], "transfer_function": "sparse"})";

TEST_F(TokenServerTest, ATokenForSomeDatasetsSeesAndOpensThoseOnly) {
  auto server = start();
  auto alpha = session(*server, kAlpha);
  EXPECT_EQ(alpha->listDatasets(), (std::vector<std::string>{"alpha-1", "alpha-2"}));
  alpha->openDataset("alpha-1");
  EXPECT_NO_THROW(alpha->render(kTokenScene));
  // beta exists, gamma does not: the same answer for both.
  const ServerError beta = refusal([&] { alpha->openDataset("beta"); });
  const ServerError gamma = refusal([&] { alpha->openDataset("gamma"); });
  EXPECT_EQ(beta.code(), proto::ErrorCode::UnknownDataset);
  EXPECT_EQ(gamma.code(), proto::ErrorCode::UnknownDataset);
  std::string b = beta.what(), g = gamma.what();
  b.replace(b.find("'beta'"), 6, "'NAME'");
  g.replace(g.find("'gamma'"), 7, "'NAME'");
  EXPECT_EQ(b, g);
  EXPECT_NO_THROW(alpha->render(kTokenScene)) << "the session goes on with alpha-1 open";
  auto all = session(*server, kAll);
  EXPECT_EQ(all->listDatasets(), (std::vector<std::string>{"alpha-1", "alpha-2", "beta"}));
  all->openDataset("beta");
  // The same over TLS, with the command line's --token-file.
  const test::TestCerts certs = test::TestCerts::make(scratch() / "token-certs");
  auto tls = start("", "--tls-cert " + certs.serverCert.string() + " --tls-key " + certs.serverKey.string());
  test::writeFile(scratch() / "alpha.token", kAlpha + "\n");
  const auto r =
      test::runVoxbrick("request 127.0.0.1:" + std::to_string(tls->port()) + " --tls --ca " + certs.caCert.string() +
                        " --token-file " + (scratch() / "alpha.token").string() + " --list");
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(r.output, "alpha-1\nalpha-2\n");
  // (The Python package speaks versions 1 to 4, without TLS or Authenticate: docs/python.md.)
  const auto denied = test::runVoxbrick(
      "request 127.0.0.1:" + std::to_string(tls->port()) + " --tls --ca " + certs.caCert.string() + " --token-file " +
      (scratch() / "alpha.token").string() + " --dataset beta -o " + (scratch() / "beta.png").string());
  EXPECT_EQ(denied.exitCode, 1);
  EXPECT_NE(denied.output.find("UnknownDataset"), std::string::npos) << denied.output;
  // The load tool's clients too, every request answered; its faulty clients speak in the clear only.
  const std::string loadArgs = "load 127.0.0.1:" + std::to_string(tls->port()) + " --tls --ca " +
                               certs.caCert.string() + " --token-file " + (scratch() / "alpha.token").string() +
                               " --dataset alpha-2 --clients 2 --duration 1 --size 32x32 --tf sparse";
  const auto load = test::runVoxbrick(loadArgs + " --require-clean");
  EXPECT_EQ(load.exitCode, 0) << load.output;
  const auto faults = test::runVoxbrick(loadArgs + " --fault-clients 1");
  EXPECT_EQ(faults.exitCode, 1);
  EXPECT_NE(faults.output.find("faulty clients speak in the clear only"), std::string::npos) << faults.output;
}

TEST_F(TokenServerTest, SessionsWithoutATokenSeeOnlyTheAnonymousDatasets) {
  auto server = start();
  // An older client (version 4 has no Authenticate): nothing, since [[tokens]] are configured.
  Client old("127.0.0.1", server->port(), 30s);
  EXPECT_EQ(old.hello("old", 4).version, 4);
  EXPECT_TRUE(old.listDatasets().empty());
  EXPECT_EQ(refusal([&] { old.openDataset("alpha-1"); }).code(), proto::ErrorCode::UnknownDataset);
  EXPECT_THROW(old.authenticate(kAlpha), std::invalid_argument) << "the client knows version 4 has no token";
  // [access] anonymous opens what it names to them.
  auto open = start("[access]\nanonymous = [\"beta\"]\n\n");
  Client anonymous("127.0.0.1", open->port(), 30s);
  anonymous.hello("old", 4);
  EXPECT_EQ(anonymous.listDatasets(), std::vector<std::string>{"beta"});
  anonymous.openDataset("beta");
  EXPECT_NO_THROW(anonymous.render(kTokenScene));
}

TEST_F(TokenServerTest, AWrongTokenIsForbiddenAndTheSessionClosed) {
  auto server = start();
  Client c("127.0.0.1", server->port(), 30s);
  c.hello();
  const ServerError wrong = refusal([&] { c.authenticate("alpha-guess"); });
  EXPECT_EQ(wrong.code(), proto::ErrorCode::Forbidden);
  EXPECT_THROW(c.listDatasets(), client::ConnectionError) << "the server closed the session";
  Client stats("127.0.0.1", server->port(), 30s);
  stats.hello();
  stats.authenticate(kAll);
  EXPECT_EQ(nlohmann::json::parse(stats.stats())["refusals"]["forbidden"].get<int>(), 1);
  // No secret reaches the log, presented or configured.
  const std::string log = server->log();
  for (const std::string& secret : {kAlpha, kAll, kTeam, kHttp, std::string("alpha-guess")})
    EXPECT_EQ(log.find(secret), std::string::npos) << secret << " in " << log;
}

TEST_F(TokenServerTest, BrowsersOpenTheSocketWithATokenAndSeeItsDatasets) {
  auto server = start();
  test::WebSocketClient alpha(server->httpPort(), "/ws?token=" + kAlpha);
  alpha.hello();
  EXPECT_EQ(alpha.listDatasets(), (std::vector<std::string>{"alpha-1", "alpha-2"}));
  EXPECT_THROW(alpha.openDataset("beta"), ServerError);
  // The single http.token opens everything, as before.
  test::WebSocketClient http(server->httpPort(), "/ws?token=" + kHttp);
  http.hello();
  EXPECT_EQ(http.listDatasets(), (std::vector<std::string>{"alpha-1", "alpha-2", "beta"}));
  EXPECT_THROW(test::WebSocketClient(server->httpPort(), "/ws"), test::UpgradeRefused);
  EXPECT_THROW(test::WebSocketClient(server->httpPort(), "/ws?token=nope"), test::UpgradeRefused);
  // The metrics name every dataset: a token that sees some of them only may not read them.
  EXPECT_EQ(test::httpRequest(server->httpPort(), "GET", "/metrics?token=" + kAlpha).status, 403);
  EXPECT_EQ(test::httpRequest(server->httpPort(), "GET", "/metrics?token=" + kAll).status, 200);
  EXPECT_EQ(test::httpRequest(server->httpPort(), "GET", "/metrics?token=" + kHttp).status, 200);
  EXPECT_EQ(test::httpRequest(server->httpPort(), "GET", "/presets.json?token=" + kAlpha).status, 200);
}

TEST_F(TokenServerTest, ATokensOwnSessionQuotaHoldsOnBothTransports) {
  auto server = start();
  auto first = session(*server, kTeam);
  EXPECT_EQ(first->listDatasets(), std::vector<std::string>{"beta"});
  Client second("127.0.0.1", server->port(), 30s);
  second.hello();
  const ServerError quota = refusal([&] { second.authenticate(kTeam); });
  EXPECT_EQ(quota.code(), proto::ErrorCode::LimitExceeded);
  EXPECT_NE(std::string(quota.what()).find("token 'team' holds 1 sessions (its sessions = 1)"), std::string::npos)
      << quota.what();
  EXPECT_TRUE(second.listDatasets().empty()) << "the session goes on, without the token";
  // A browser's token comes with the upgrade: its Hello is refused (id 0), and the server closes.
  test::WebSocketClient browser(server->httpPort(), "/ws?token=" + kTeam);
  browser.send(proto::Hello{1, 4, "browser"});
  EXPECT_EQ(browser.errorsUntilClosed(), std::vector<proto::ErrorCode>{proto::ErrorCode::LimitExceeded});
  first->goodbye();
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(session(*server, kTeam)->listDatasets(), std::vector<std::string>{"beta"}) << "its place is free again";
}

}  // namespace
}  // namespace voxbrick::token_server_tests
