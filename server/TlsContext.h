// The server's TLS: one OpenSSL context for both listeners, made from the [tls] files (certificate chain, key,
// optional CA of client certificates) with the policy every connection gets (TLS 1.2 or later, ECDHE key exchange with
// AEAD ciphers only, no compression, no renegotiation, no session tickets), and replaced whole when the files are
// read again (SIGHUP): a connection keeps the context it was accepted with, new handshakes take the new one.
#pragma once

#include <filesystem>
#include <memory>
#include <mutex>
#include <string>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/ssl/context.hpp>

#include "server/ServerConfig.h"

namespace voxbrick::server {

/// The TLS 1.2 ciphers the server offers (ECDHE key exchange, AEAD only); TLS 1.3's are all AEAD.
inline constexpr const char* kTls12Ciphers =
    "ECDHE-ECDSA-AES128-GCM-SHA256:ECDHE-RSA-AES128-GCM-SHA256:ECDHE-ECDSA-AES256-GCM-SHA384:"
    "ECDHE-RSA-AES256-GCM-SHA384:ECDHE-ECDSA-CHACHA20-POLY1305:ECDHE-RSA-CHACHA20-POLY1305";
inline constexpr const char* kTls13Ciphers =
    "TLS_AES_128_GCM_SHA256:TLS_AES_256_GCM_SHA384:TLS_CHACHA20_POLY1305_SHA256";

/// A server context with the policy above, loaded from `files`. Throws std::runtime_error naming the file and the
/// problem (unreadable, not PEM, a key that does not belong to the certificate, an expired certificate).
std::shared_ptr<boost::asio::ssl::context> makeServerTlsContext(const TlsFiles& files);

/// One line about the certificate in `files.cert`: its subject and the date it expires (for the log).
std::string describeCertificate(const std::filesystem::path& cert);

/// The context new connections are accepted with, and its replacement. Thread-safe.
class TlsContexts {
 public:
  /// Loads `files` now (makeServerTlsContext; throws the same).
  explicit TlsContexts(TlsFiles files);

  /// The context for the next handshake.
  std::shared_ptr<boost::asio::ssl::context> current() const;
  /// Reads the files again and makes the new context current; on failure keeps the old one and throws
  /// std::runtime_error naming the problem. Connections already open keep theirs.
  void reload();
  const TlsFiles& files() const { return mFiles; }

 private:
  const TlsFiles mFiles;
  mutable std::mutex mMutex;
  std::shared_ptr<boost::asio::ssl::context> mCurrent;
};

/// The reason an OpenSSL failure gives, as a short text (e.g. "unsupported protocol", "no shared cipher"): the
/// message of an error of Asio's SSL category, with OpenSSL's library and function names left out.
std::string tlsFailureText(const boost::system::error_code& ec);

}  // namespace voxbrick::server
