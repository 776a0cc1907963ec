// `voxbrick token --id ID --datasets PATTERN...`: a new access token, its secret shown once (or written to a file of
// its own) and the [[tokens]] entry for server.toml, which holds only the secret's SHA-256; `--hash` the SHA-256 of a
// secret read from stdin.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "cli/Commands.h"
#include "server/AccessTokens.h"
#include "server/ServerConfig.h"

namespace voxbrick::cli {
namespace {

struct TokenArgs {
  std::string id, secretFile;
  std::vector<std::string> datasets;
  int sessions = -1;
  double framesPerSecond = -1;
  bool hash = false;
};

std::string tomlString(const std::string& text) { return "\"" + text + "\""; }

void runToken(const TokenArgs& a) {
  if (a.hash) {
    std::string secret;
    std::getline(std::cin, secret);
    while (!secret.empty() && (secret.back() == '\r' || secret.back() == ' ')) secret.pop_back();
    if (secret.empty()) throw std::invalid_argument("--hash: no secret on the first line of stdin");
    std::printf("%s\n", server::AccessTokens::sha256Hex(secret).c_str());
    return;
  }
  if (a.id.empty()) throw std::invalid_argument("--id is required: the token's name in logs and the audit trail");
  if (a.datasets.empty())
    throw std::invalid_argument(
        "--datasets is required: the datasets the token may open (names or patterns, * for all)");
  const std::string secret = server::AccessTokens::newSecret();
  server::TokenConfig token;
  token.id = a.id;
  token.sha256 = server::AccessTokens::sha256Hex(secret);
  token.datasets = a.datasets;
  if (a.sessions >= 0) token.sessions = a.sessions;
  if (a.framesPerSecond >= 0) token.framesPerSecond = a.framesPerSecond;
  server::ServerConfig check;  // the entry is checked as the server will read it
  check.tokens = {token};
  check.validateTokens();
  if (!a.secretFile.empty()) {
    // Readable by its owner alone, and never an existing file: a secret is not written over another.
    const int fd = ::open(a.secretFile.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0600);
    if (fd < 0)
      throw std::runtime_error("--secret-file '" + a.secretFile + "' cannot be created: " + std::strerror(errno));
    const std::string line = secret + "\n";
    const bool written = ::write(fd, line.data(), line.size()) == ssize_t(line.size());
    ::close(fd);
    if (!written) throw std::runtime_error("--secret-file '" + a.secretFile + "' could not be written");
    std::printf("# the secret is in %s (mode 0600): hand it to the token's holder\n", a.secretFile.c_str());
  } else {
    std::printf(
        "# the secret, shown only now: hand it to the token's holder (voxbrick request --token-file, or the\n"
        "# viewer's address with ?token=SECRET); server.toml keeps only its SHA-256\n%s\n",
        secret.c_str());
  }
  std::printf("\n# add to server.toml:\n[[tokens]]\nid = %s\nsha256 = %s\ndatasets = [", tomlString(token.id).c_str(),
              tomlString(token.sha256).c_str());
  for (size_t i = 0; i < token.datasets.size(); ++i)
    std::printf("%s%s", i ? ", " : "", tomlString(token.datasets[i]).c_str());
  std::printf("]\n");
  if (token.sessions) std::printf("sessions = %d\n", *token.sessions);
  if (token.framesPerSecond) std::printf("frames_per_s = %s\n", formatNumber(*token.framesPerSecond).c_str());
}

}  // namespace

void addTokenCommand(CLI::App& app) {
  auto a = std::make_shared<TokenArgs>();
  CLI::App* cmd = app.add_subcommand(
      "token", "Make an access token: its secret, and its [[tokens]] entry for server.toml (which keeps only a hash)");
  cmd->add_option("--id", a->id, "the token's name, in logs and the audit trail (letters, digits, . - _)");
  cmd->add_option("--datasets", a->datasets,
                  "datasets the token may list and open: names or glob patterns (* ? [...]), * for every one; "
                  "repeatable")
      ->allow_extra_args(false);
  cmd->add_option("--sessions", a->sessions,
                  "sessions it may hold at once (default none: quotas.sessions_per_token of the server)")
      ->check(between(0, 100000));
  cmd->add_option("--frames-per-s", a->framesPerSecond,
                  "Renders a second its sessions may send together (default none: quotas.frames_per_s_per_token)")
      ->check(between(0, 1e6));
  cmd->add_option("--secret-file", a->secretFile,
                  "write the secret to this new file (mode 0600) instead of printing it (default none: printed)");
  cmd->add_flag("--hash", a->hash, "print the SHA-256 of a secret read from stdin's first line, and nothing else");
  cmd->callback([a] { runToken(*a); });
}

}  // namespace voxbrick::cli
