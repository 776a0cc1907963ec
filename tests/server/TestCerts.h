// Certificates for the TLS tests, made at test time with Debian's `openssl` command: a test CA, a server certificate
// it signs for 127.0.0.1 and localhost, a second ("wrong") CA with a certificate of its own for the same names, a
// certificate of the test CA for another name only, and a client certificate of the test CA (mutual TLS).
#pragma once

#include <filesystem>
#include <string>

namespace voxbrick::test {

struct TestCerts {
  std::filesystem::path caCert;      ///< the test CA (PEM)
  std::filesystem::path serverCert;  ///< for IP 127.0.0.1 and DNS localhost, signed by caCert
  std::filesystem::path serverKey;
  std::filesystem::path otherCert;  ///< a second server certificate of the test CA, same names (the reload)
  std::filesystem::path otherKey;
  std::filesystem::path wrongCaCert;  ///< another CA, which signed none of the above
  std::filesystem::path wrongCert;    ///< for 127.0.0.1 and localhost, signed by wrongCaCert
  std::filesystem::path wrongKey;
  std::filesystem::path elsewhereCert;  ///< signed by caCert, for DNS elsewhere.example only
  std::filesystem::path elsewhereKey;
  std::filesystem::path clientCert;  ///< a client certificate signed by caCert
  std::filesystem::path clientKey;

  /// Makes them all in `dir` (about 0.2 s); throws std::runtime_error with openssl's output if it fails.
  static TestCerts make(const std::filesystem::path& dir);
  /// The SHA-256 of `cert`'s public key (its SPKI) in base 64, as Chromium's --ignore-certificate-errors-spki-list
  /// takes it.
  static std::string spkiHash(const std::filesystem::path& cert);
};

}  // namespace voxbrick::test
