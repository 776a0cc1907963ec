// Access tokens on their own and in the message handler: SHA-256 hashes compared in constant time, dataset patterns,
// what a session without a token sees, the [[tokens]] of server.toml and their errors; a session's listing filtered
// and a dataset it may not open refused in the very words of a missing one; Authenticate in version 5 only.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "TestDatasets.h"
#include "render/core/TransferFunctionPresets.h"
#include "server/AccessTokens.h"
#include "server/Datasets.h"
#include "server/MessageHandler.h"
#include "server/ServerConfig.h"
#include "server/ServerStats.h"
#include "support/TestSupport.h"

namespace voxbrick::server::token_tests {
namespace {

using proto::ErrorCode;

/// Two secrets; server.toml holds their SHA-256 only.
const std::string kAlphaSecret = "alpha-secret", kOtherSecret = "other-secret";

TokenConfig tokenOf(const std::string& id, const std::string& secret, std::vector<std::string> datasets) {
  TokenConfig t;
  t.id = id;
  t.sha256 = AccessTokens::sha256Hex(secret);
  t.datasets = std::move(datasets);
  return t;
}

TEST(AccessTokens, SecretsAreHashedWithSha256AndOnlyTheRightOneMatches) {
  EXPECT_EQ(AccessTokens::sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(AccessTokens::sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  ServerConfig config;
  config.tokens = {tokenOf("alpha", kAlphaSecret, {"alpha-*"}), tokenOf("other", kOtherSecret, {"beta"})};
  const AccessTokens tokens(config);
  EXPECT_TRUE(tokens.configured());
  ASSERT_TRUE(tokens.match(kAlphaSecret));
  EXPECT_EQ(tokens.match(kAlphaSecret)->id, "alpha");
  EXPECT_EQ(tokens.match(kOtherSecret)->id, "other");
  for (const std::string& wrong : std::vector<std::string>{"", "alpha", "alpha-secre", "alpha-secret ", "ALPHA-SECRET",
                                                           AccessTokens::sha256Hex(kAlphaSecret)})
    EXPECT_FALSE(tokens.match(wrong)) << wrong;
  // A hash in upper case is the same hash.
  config.tokens[0].sha256 = AccessTokens::sha256Hex(kAlphaSecret);
  for (char& c : config.tokens[0].sha256) c = char(std::toupper(static_cast<unsigned char>(c)));
  EXPECT_EQ(AccessTokens(config).match(kAlphaSecret)->id, "alpha");
  // New secrets are 64 hex digits, and differ.
  const std::string a = AccessTokens::newSecret(), b = AccessTokens::newSecret();
  EXPECT_EQ(a.size(), 64u);
  EXPECT_NE(a, b);
}

TEST(AccessTokens, OnlyTokensGrantedItAndTheServersOwnMayUpload) {
  ServerConfig config;
  config.tokens = {tokenOf("alpha", kAlphaSecret, {"alpha-*"}), tokenOf("other", kOtherSecret, {"beta"})};
  config.tokens[1].upload = true;
  config.httpToken = "the-operators-token";
  const AccessTokens tokens(config);
  EXPECT_FALSE(tokens.match(kAlphaSecret)->upload);
  EXPECT_TRUE(tokens.match(kOtherSecret)->upload);
  EXPECT_TRUE(tokens.match("the-operators-token")->upload);
  EXPECT_FALSE(tokens.anonymous()->upload);
}

TEST(AccessTokens, PatternsSayWhichDatasetsATokenMayOpen) {
  const TokenGrant grant{"g", {"alpha-*", "beta", "gamma-[12]"}, std::nullopt, std::nullopt};
  EXPECT_TRUE(grant.mayOpen("alpha-1"));
  EXPECT_TRUE(grant.mayOpen("alpha-"));
  EXPECT_TRUE(grant.mayOpen("beta"));
  EXPECT_TRUE(grant.mayOpen("gamma-2"));
  EXPECT_FALSE(grant.mayOpen("gamma-3"));
  EXPECT_FALSE(grant.mayOpen("betamax"));
  EXPECT_FALSE(grant.mayOpen("alpha"));
  EXPECT_FALSE(grant.everything());
  EXPECT_TRUE((TokenGrant{"all", {"*"}, std::nullopt, std::nullopt}).everything());
}

TEST(AccessTokens, ASessionWithoutATokenSeesEverythingUntilTokensAreConfigured) {
  ServerConfig none;
  EXPECT_FALSE(AccessTokens(none).configured());
  EXPECT_TRUE(AccessTokens(none).anonymous()->everything());
  // The single http.token opens everything, and leaves TCP sessions without one as they were.
  ServerConfig http;
  http.httpToken = "s3cret";
  const AccessTokens httpTokens(http);
  EXPECT_TRUE(httpTokens.configured());
  EXPECT_EQ(httpTokens.match("s3cret")->id, "http.token");
  EXPECT_TRUE(httpTokens.match("s3cret")->everything());
  EXPECT_TRUE(httpTokens.anonymous()->everything());
  // [[tokens]]: a session without one sees nothing, unless [access] anonymous says what.
  ServerConfig scoped;
  scoped.tokens = {tokenOf("alpha", kAlphaSecret, {"alpha-*"})};
  EXPECT_TRUE(AccessTokens(scoped).anonymous()->datasets.empty());
  scoped.anonymousDatasets = std::vector<std::string>{"beta"};
  EXPECT_TRUE(AccessTokens(scoped).anonymous()->mayOpen("beta"));
  EXPECT_FALSE(AccessTokens(scoped).anonymous()->mayOpen("alpha-1"));
  // One secret cannot be two tokens.
  scoped.httpToken = kAlphaSecret;
  EXPECT_THROW(AccessTokens{scoped}, std::runtime_error);
}

class TokenConfigTest : public ::testing::Test {
 protected:
  test::ScratchDir dir;
  /// The error loading `toml` gives ("" when it loads).
  std::string loadError(const std::string& toml) {
    const auto path = dir / "server.toml";
    std::ofstream(path) << toml;
    try {
      ServerConfig::load(path);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  }
};

TEST_F(TokenConfigTest, TokensAreReadFromServerToml) {
  const std::string hash = AccessTokens::sha256Hex(kAlphaSecret);
  const auto path = dir / "server.toml";
  std::ofstream(path) << "[access]\nanonymous = [\"beta\"]\n\n[[tokens]]\nid = \"alpha\"\nsha256 = \"" << hash
                      << "\"\ndatasets = [\"alpha-*\", \"beta\"]\nsessions = 2\nframes_per_s = 7.5\n\n"
                      << "[[tokens]]\nid = \"all\"\nsha256 = \"" << AccessTokens::sha256Hex(kOtherSecret)
                      << "\"\ndatasets = [\"*\"]\n";
  const ServerConfig c = ServerConfig::load(path);
  ASSERT_EQ(c.tokens.size(), 2u);
  EXPECT_EQ(c.tokens[0].id, "alpha");
  EXPECT_EQ(c.tokens[0].sha256, hash);
  EXPECT_EQ(c.tokens[0].datasets, (std::vector<std::string>{"alpha-*", "beta"}));
  EXPECT_EQ(c.tokens[0].sessions, 2);
  EXPECT_EQ(c.tokens[0].framesPerSecond, 7.5);
  EXPECT_EQ(c.tokens[1].sessions, std::nullopt);
  EXPECT_EQ(c.anonymousDatasets, std::vector<std::string>{"beta"});
}

TEST_F(TokenConfigTest, ABadTokenIsRefusedNamingItAndTheProblem) {
  const std::string hash = AccessTokens::sha256Hex(kAlphaSecret);
  const auto token = [&](const std::string& body) { return "[[tokens]]\n" + body; };
  const std::string good = "sha256 = \"" + hash + "\"\ndatasets = [\"*\"]\n";
  struct Case {
    std::string toml, says;
  };
  const std::vector<Case> cases = {
      {token(good), "tokens[1]: id is missing"},
      {token("id = \"a b\"\n" + good), "id must be at most 64 letters, digits"},
      {token("id = \"http.token\"\n" + good), "the id http.token is the single token of [http]"},
      {token("id = \"a\"\n" + good) +
           token("id = \"a\"\nsha256 = \"" + AccessTokens::sha256Hex("x") + "\"\ndatasets = [\"*\"]\n"),
       "tokens[2] ('a'): id 'a' is given to two tokens"},
      {token("id = \"a\"\n" + good) + token("id = \"b\"\n" + good), "its sha256 is that of 'a' too"},
      {token("id = \"a\"\nsha256 = \"abc\"\ndatasets = [\"*\"]\n"), "sha256 must be the 64 hex digits"},
      {token("id = \"a\"\nsha256 = \"" + std::string(64, 'g') + "\"\ndatasets = [\"*\"]\n"), "64 hex digits"},
      {token("id = \"a\"\nsha256 = \"" + hash + "\"\n"), "datasets is missing"},
      {token("id = \"a\"\nsha256 = \"" + hash + "\"\ndatasets = [\"../etc\"]\n"), "'../etc' is not a dataset name"},
      {token("id = \"a\"\n" + good + "secret = \"x\"\n"), "unknown key tokens[1].secret"},
      {token("id = \"a\"\n" + good + "sessions = -1\n"), "tokens[1].sessions = -1 is out of range"},
      {"tokens = 3\n", "tokens must be an array of tables"},
      {"[access]\nanonymous = [\"a/b\"]\n", "access.anonymous: 'a/b' is not a dataset name"},
      {"[access]\nwho = 1\n", "unknown key access.who"},
  };
  for (const Case& c : cases) {
    const std::string error = loadError(c.toml);
    EXPECT_NE(error.find(c.says), std::string::npos) << "for:\n" << c.toml << "\ngot: " << error;
    EXPECT_NE(error.find((dir / "server.toml").string()), std::string::npos) << error;
  }
}

/// The handler over a directory of three datasets (copies of the test store): alpha-1, alpha-2 and beta.
class ScopedHandlerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sDir = new test::ScratchDir();
    for (const char* name : {"alpha-1", "alpha-2", "beta"})
      std::filesystem::copy(test::testDatasets() / "sparse", *sDir / name, std::filesystem::copy_options::recursive);
  }
  static void TearDownTestSuite() {
    delete sDir;
    sDir = nullptr;
  }
  static ServerConfig scopedConfig() {
    ServerConfig c;
    c.tokens = {tokenOf("alpha", kAlphaSecret, {"alpha-*"}), tokenOf("other", kOtherSecret, {"*"})};
    return c;
  }

  ServerConfig config = scopedConfig();
  std::shared_ptr<const AccessTokens> tokens = std::make_shared<const AccessTokens>(config);
  DatasetRegistry datasets{sDir->path(), size_t(16) << 20};
  render::TransferFunctionPresets presets = render::TransferFunctionPresets::load(test::shippedPresets());
  ServerStats stats;
  MessageHandler handler{config,
                         datasets,
                         presets,
                         stats,
                         [this] {
                           return stats.toJson(ServerStats::Gauges{1, 0, datasets.opened(), 1, {}, 0});
                         },
                         tokens};
  ConnectionState state;

  void SetUp() override { state.access = tokens->anonymous(); }
  Outcome handle(const proto::Message& message, uint32_t id = 1) { return handler.handle(state, message, id); }
  void greet(uint16_t maxVersion = proto::kMaxVersion) {
    ASSERT_EQ(handle(proto::Hello{1, maxVersion, "test"}).replies.size(), 1u);
  }
  std::vector<std::string> listed() {
    const Outcome o = handle(proto::ListDatasets{});
    return o.replies.size() == 1 && std::holds_alternative<proto::DatasetList>(o.replies[0].message)
               ? std::get<proto::DatasetList>(o.replies[0].message).names
               : std::vector<std::string>{"?"};
  }
  /// The Error `outcome`'s one reply is.
  static proto::Error errorOf(const Outcome& outcome) {
    EXPECT_EQ(outcome.replies.size(), 1u);
    const auto* e = outcome.replies.empty() ? nullptr : std::get_if<proto::Error>(&outcome.replies[0].message);
    return e ? *e : proto::Error{ErrorCode::Internal, "no Error"};
  }

  static inline test::ScratchDir* sDir = nullptr;
};

TEST_F(ScopedHandlerTest, ATokenListsAndOpensItsDatasetsOnlyAndOthersAreRefusedAsMissing) {
  greet();
  EXPECT_TRUE(listed().empty()) << "without a token, nothing: tokens are configured";
  const Outcome ok = handle(proto::Authenticate{kAlphaSecret}, 2);
  ASSERT_EQ(ok.replies.size(), 1u);
  EXPECT_EQ(std::get<proto::Authenticated>(ok.replies[0].message).tokenId, "alpha");
  EXPECT_FALSE(ok.close);
  EXPECT_EQ(listed(), (std::vector<std::string>{"alpha-1", "alpha-2"}));
  // beta exists, delta does not: the same refusal, word for word, and no name the token may not see.
  const proto::Error forbidden = errorOf(handle(proto::OpenDataset{"beta"}));
  const proto::Error missing = errorOf(handle(proto::OpenDataset{"delta"}));
  EXPECT_EQ(forbidden.code, ErrorCode::UnknownDataset);
  EXPECT_EQ(missing.code, ErrorCode::UnknownDataset);
  const auto withoutName = [](std::string text, const std::string& name) {
    return text.replace(text.find(name), name.size(), "NAME");
  };
  EXPECT_EQ(withoutName(forbidden.message, "'beta'"), withoutName(missing.message, "'delta'"));
  EXPECT_EQ(forbidden.message.find("beta", forbidden.message.find("'beta'") + 6), std::string::npos)
      << forbidden.message;
  EXPECT_EQ(errorOf(handle(proto::OpenDataset{"betb"})).message.find("beta"), std::string::npos)
      << "a name it may not see is never suggested";
  EXPECT_FALSE(state.dataset);
  ASSERT_EQ(handle(proto::OpenDataset{"alpha-2"}).replies.size(), 1u);
  ASSERT_TRUE(state.dataset);
  EXPECT_EQ(state.dataset->name(), "alpha-2");
  // The statistics show the datasets it may see only.
  const Outcome statsReply = handle(proto::GetStats{});
  const auto statsJson = nlohmann::json::parse(std::get<proto::Stats>(statsReply.replies[0].message).json);
  for (const auto& dataset : statsJson["datasets"]) EXPECT_NE(dataset["name"], "beta");
}

TEST_F(ScopedHandlerTest, AuthenticateIsVersionFiveOnlyOnceAndBeforeOpenDataset) {
  greet(4);
  EXPECT_EQ(errorOf(handle(proto::Authenticate{kAlphaSecret})).code, ErrorCode::UnknownType);
  EXPECT_FALSE(state.authenticated);
  state = ConnectionState{};
  state.access = tokens->anonymous();
  greet();
  const Outcome wrong = handle(proto::Authenticate{"guess"});
  EXPECT_EQ(errorOf(wrong).code, ErrorCode::Forbidden);
  EXPECT_EQ(errorOf(wrong).message, "wrong access token");
  EXPECT_TRUE(wrong.close) << "a wrong token ends the session";
  EXPECT_EQ(stats.refusals(Refusal::Forbidden), 1u);
  ASSERT_EQ(handle(proto::Authenticate{kOtherSecret}).replies.size(), 1u);
  EXPECT_EQ(listed(), (std::vector<std::string>{"alpha-1", "alpha-2", "beta"}));
  EXPECT_EQ(errorOf(handle(proto::Authenticate{kAlphaSecret})).code, ErrorCode::UnexpectedMessage);
  state = ConnectionState{};
  state.access = tokens->anonymous();
  state.access = std::make_shared<TokenGrant>(TokenGrant{"", {"beta"}, std::nullopt, std::nullopt});
  greet();
  ASSERT_EQ(handle(proto::OpenDataset{"beta"}).replies.size(), 1u);
  const proto::Error late = errorOf(handle(proto::Authenticate{kAlphaSecret}));
  EXPECT_EQ(late.code, ErrorCode::UnexpectedMessage);
  EXPECT_NE(late.message.find("before OpenDataset"), std::string::npos) << late.message;
}

}  // namespace
}  // namespace voxbrick::server::token_tests
