// The options of a command that connects to a running server (`request`, `load`): TLS (--tls, --ca, --tls-insecure, a
// client certificate) and the access token the session presents (--token-file, or $VOXBRICK_TOKEN).
#pragma once

#include <CLI/CLI.hpp>

#include <chrono>
#include <memory>
#include <string>

#include "client/Client.h"

namespace voxbrick::cli {

struct ConnectArgs {
  bool tls = false, insecure = false;
  std::string ca, cert, key, tokenFile;
};

/// Adds the options to `cmd`.
void addConnectOptions(CLI::App* cmd, ConnectArgs& args);
/// The client's TLS options as given.
client::TlsOptions tlsOptionsOf(const ConnectArgs& args);
/// The access token to present: the first line of --token-file, else $VOXBRICK_TOKEN, else empty (none). Throws
/// std::runtime_error naming a file that cannot be read or holds no token.
std::string accessTokenOf(const ConnectArgs& args);

}  // namespace voxbrick::cli
