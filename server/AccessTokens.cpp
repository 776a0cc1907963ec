// Token hashes, constant-time matching and dataset patterns.
#include "server/AccessTokens.h"

#include <fnmatch.h>

#include <algorithm>
#include <stdexcept>

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>

namespace voxbrick::server {
namespace {

std::vector<unsigned char> sha256(std::string_view text) {
  std::vector<unsigned char> digest(EVP_MAX_MD_SIZE);
  unsigned int size = 0;
  if (EVP_Digest(text.data(), text.size(), digest.data(), &size, EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("SHA-256 failed (OpenSSL EVP_Digest)");
  digest.resize(size);
  return digest;
}

std::string hex(const std::vector<unsigned char>& bytes) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (const unsigned char b : bytes) {
    out += digits[b >> 4];
    out += digits[b & 15];
  }
  return out;
}

/// The bytes of 64 hex digits (validated by ServerConfig::validate).
std::vector<unsigned char> unhex(std::string_view text) {
  const auto value = [](char c) { return c <= '9' ? c - '0' : (c | 0x20) - 'a' + 10; };
  std::vector<unsigned char> out;
  for (size_t i = 0; i + 1 < text.size(); i += 2)
    out.push_back(static_cast<unsigned char>(value(text[i]) * 16 + value(text[i + 1])));
  return out;
}

}  // namespace

bool TokenGrant::mayOpen(std::string_view name) const {
  const std::string text(name);
  return std::any_of(datasets.begin(), datasets.end(),
                     [&](const std::string& pattern) { return ::fnmatch(pattern.c_str(), text.c_str(), 0) == 0; });
}

bool TokenGrant::everything() const { return std::find(datasets.begin(), datasets.end(), "*") != datasets.end(); }

AccessTokens::AccessTokens(const ServerConfig& config) {
  for (const TokenConfig& token : config.tokens) {
    auto grant = std::make_shared<TokenGrant>();
    grant->id = token.id;
    grant->datasets = token.datasets;
    grant->sessions = token.sessions;
    grant->framesPerSecond = token.framesPerSecond;
    grant->upload = token.upload;
    mTokens.push_back({unhex(token.sha256), std::move(grant)});
  }
  if (!config.httpToken.empty()) {
    if (match(config.httpToken))
      throw std::runtime_error("http.token is the secret of token '" + match(config.httpToken)->id +
                               "' of [[tokens]] too: one secret, two tokens");
    auto grant = std::make_shared<TokenGrant>();
    grant->id = "http.token";
    grant->datasets = {"*"};
    grant->upload = true;  // the server's one token: its operator's
    mTokens.push_back({sha256(config.httpToken), std::move(grant)});
  }
  auto anonymous = std::make_shared<TokenGrant>();
  if (config.anonymousDatasets)
    anonymous->datasets = *config.anonymousDatasets;
  else if (config.tokens.empty())
    anonymous->datasets = {"*"};
  mAnonymous = std::move(anonymous);
}

std::shared_ptr<const TokenGrant> AccessTokens::match(std::string_view secret) const {
  const std::vector<unsigned char> digest = sha256(secret);
  std::shared_ptr<const TokenGrant> found;
  // Every hash is compared, the match or not: the time taken says nothing of which token, if any, is near.
  for (const Stored& stored : mTokens)
    if (stored.digest.size() == digest.size() && CRYPTO_memcmp(stored.digest.data(), digest.data(), digest.size()) == 0)
      found = stored.grant;
  return found;
}

std::string AccessTokens::sha256Hex(std::string_view text) { return hex(sha256(text)); }

std::string AccessTokens::newSecret() {
  std::vector<unsigned char> bytes(32);
  if (RAND_bytes(bytes.data(), int(bytes.size())) != 1)
    throw std::runtime_error("no random bytes (OpenSSL RAND_bytes)");
  return hex(bytes);
}

}  // namespace voxbrick::server
