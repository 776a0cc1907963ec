// TLS and access-token options of the commands that connect to a server.
#include "cli/ConnectOptions.h"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace voxbrick::cli {

void addConnectOptions(CLI::App* cmd, ConnectArgs& a) {
  CLI::Option* tls = cmd->add_flag("--tls", a.tls,
                                   "speak TLS to the server (one started with --tls-cert speaks nothing else), its "
                                   "certificate verified against the system's CAs or --ca");
  cmd->add_option("--ca", a.ca,
                  "PEM certificates of the CAs that may sign the server's certificate (default the system's CAs)")
      ->check(CLI::ExistingFile)
      ->needs(tls);
  cmd->add_flag("--tls-insecure", a.insecure,
                "with --tls, take any certificate without verifying it: for a self-signed certificate in local use "
                "only (the link is encrypted, but anyone on the path could pose as the server)")
      ->needs(tls);
  cmd->add_option("--cert", a.cert,
                  "PEM certificate of this client, for a server that asks one: its tls.ca (default none)")
      ->check(CLI::ExistingFile)
      ->needs(tls);
  cmd->add_option("--key", a.key, "PEM private key of --cert (default none)")->check(CLI::ExistingFile)->needs(tls);
  cmd->add_option("--token-file", a.tokenFile,
                  "file whose first line is the access token the session presents; a token given on the command line "
                  "would show in the process list (default $VOXBRICK_TOKEN if set, else none)")
      ->check(CLI::ExistingFile);
}

client::TlsOptions tlsOptionsOf(const ConnectArgs& a) {
  client::TlsOptions tls;
  tls.enabled = a.tls;
  tls.caFile = a.ca;
  tls.insecure = a.insecure;
  tls.certFile = a.cert;
  tls.keyFile = a.key;
  return tls;
}

std::string accessTokenOf(const ConnectArgs& a) {
  if (a.tokenFile.empty()) {
    const char* env = std::getenv("VOXBRICK_TOKEN");
    return env ? std::string(env) : std::string();
  }
  std::ifstream in(a.tokenFile);
  if (!in) throw std::runtime_error("--token-file '" + a.tokenFile + "' cannot be read: " + std::strerror(errno));
  std::string token;
  std::getline(in, token);
  while (!token.empty() && (token.back() == '\r' || token.back() == ' ')) token.pop_back();
  if (token.empty()) throw std::runtime_error("--token-file '" + a.tokenFile + "' holds no token on its first line");
  return token;
}

}  // namespace voxbrick::cli
