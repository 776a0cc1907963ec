// Access tokens and what each may see: the tokens of server.toml ([[tokens]]: an id, the SHA-256 of the secret, the
// datasets it may list and open as names or glob patterns, optional quotas), the single http.token (one that opens
// every dataset), and the datasets a session without a token may see ([access] anonymous). Secrets are never kept:
// a presented token is hashed and compared in constant time with every stored hash. No sockets; thread-safe (const
// after construction).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "server/ServerConfig.h"

namespace voxbrick::server {

/// What one token (or the absence of one) opens.
struct TokenGrant {
  std::string id;                         ///< as configured ("http.token" for the single one); empty: no token
  std::vector<std::string> datasets;      ///< names or glob patterns (fnmatch: *, ?, [...]) it may list and open
  std::optional<int> sessions;            ///< its own sessions quota, in place of [quotas] sessions_per_token
  std::optional<double> framesPerSecond;  ///< its own frame-rate quota, in place of frames_per_s_per_token
  bool upload = false;                    ///< it may send volumes to become datasets (the single http.token may)

  bool anonymous() const { return id.empty(); }
  /// Whether it may list and open the dataset `name`.
  bool mayOpen(std::string_view name) const;
  /// Whether it opens every dataset there is or will be (a pattern "*"): it may read what names them all (the
  /// metrics).
  bool everything() const;
};

class AccessTokens {
 public:
  /// The tokens of `config` (config.tokens, config.httpToken, config.anonymousDatasets), checked by
  /// ServerConfig::validate.
  explicit AccessTokens(const ServerConfig& config);

  /// Whether any token is configured: then /ws needs one, and sessions without one see the anonymous datasets only.
  bool configured() const { return !mTokens.empty(); }
  /// The grant of the token whose secret is `secret`, or null for none. Every stored hash is compared, in constant
  /// time, whichever matches.
  std::shared_ptr<const TokenGrant> match(std::string_view secret) const;
  /// What a session without a token may see: [access] anonymous, by default every dataset when no [[tokens]] are
  /// configured (http.token alone keeps TCP sessions as they were), none otherwise.
  const std::shared_ptr<const TokenGrant>& anonymous() const { return mAnonymous; }

  /// The SHA-256 of `text`, 64 lower-case hex digits (OpenSSL's EVP).
  static std::string sha256Hex(std::string_view text);
  /// A new secret: 32 random bytes (OpenSSL's RAND_bytes) as 64 hex digits.
  static std::string newSecret();

 private:
  struct Stored {
    std::vector<unsigned char> digest;  ///< SHA-256 of the secret
    std::shared_ptr<const TokenGrant> grant;
  };
  std::vector<Stored> mTokens;
  std::shared_ptr<const TokenGrant> mAnonymous;
};

}  // namespace voxbrick::server
