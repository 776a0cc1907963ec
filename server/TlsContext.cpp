// The server's TLS context: its policy, its files read with errors that name them, and its replacement on reload.
#include "server/TlsContext.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <stdexcept>

#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>

namespace voxbrick::server {
namespace {

namespace ssl = boost::asio::ssl;

/// Named apart from ServerConfig.cpp's fail(): a unity build may put both files in one unit.
[[noreturn]] void tlsFail(const std::string& what) { throw std::runtime_error(what); }

/// OpenSSL's queued errors as one text (the queue emptied), or `fallback` when there are none.
std::string openSslErrors(const std::string& fallback) {
  std::string out;
  while (const unsigned long code = ERR_get_error()) {
    const char* reason = ERR_reason_error_string(code);
    if (!out.empty()) out += "; ";
    out += reason ? reason : "error " + std::to_string(code);
  }
  return out.empty() ? fallback : out;
}

/// Throws naming `what` and `path` unless the file can be opened for reading.
void checkReadable(const char* what, const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) tlsFail(std::string(what) + " '" + path.string() + "' cannot be read: " + std::strerror(errno));
}

/// The first certificate of the PEM file `path`; throws naming the file when it holds none.
std::unique_ptr<X509, decltype(&X509_free)> readCertificate(const std::filesystem::path& path) {
  std::unique_ptr<FILE, decltype(&std::fclose)> file(std::fopen(path.c_str(), "r"), &std::fclose);
  if (!file) tlsFail("tls.cert '" + path.string() + "' cannot be read: " + std::strerror(errno));
  std::unique_ptr<X509, decltype(&X509_free)> cert(PEM_read_X509(file.get(), nullptr, nullptr, nullptr), &X509_free);
  if (!cert) tlsFail("tls.cert '" + path.string() + "' holds no PEM certificate: " + openSslErrors("nothing readable"));
  return cert;
}

std::string asn1Time(const ASN1_TIME* time) {
  struct tm t {};
  if (ASN1_TIME_to_tm(time, &t) != 1) return "?";
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S UTC", &t);
  return text;
}

}  // namespace

std::string describeCertificate(const std::filesystem::path& path) {
  const auto cert = readCertificate(path);
  char subject[256] = {};
  X509_NAME_oneline(X509_get_subject_name(cert.get()), subject, sizeof subject - 1);
  return std::string(subject) + ", valid until " + asn1Time(X509_get0_notAfter(cert.get()));
}

std::shared_ptr<ssl::context> makeServerTlsContext(const TlsFiles& files) {
  checkReadable("tls.cert", files.cert);
  checkReadable("tls.key", files.key);
  if (!files.ca.empty()) checkReadable("tls.ca", files.ca);
  // An expired certificate is refused by every client: better said at start (or at a reload) than at each handshake.
  {
    const auto cert = readCertificate(files.cert);
    if (X509_cmp_current_time(X509_get0_notAfter(cert.get())) <= 0)
      tlsFail("tls.cert '" + files.cert.string() + "' expired on " + asn1Time(X509_get0_notAfter(cert.get())));
  }
  auto context = std::make_shared<ssl::context>(ssl::context::tls_server);
  SSL_CTX* ctx = context->native_handle();
  ERR_clear_error();
  if (SSL_CTX_set_min_proto_version(ctx, TLS1_2_VERSION) != 1 || SSL_CTX_set_cipher_list(ctx, kTls12Ciphers) != 1 ||
      SSL_CTX_set_ciphersuites(ctx, kTls13Ciphers) != 1)
    tlsFail("the TLS policy cannot be set: " + openSslErrors("unknown failure"));
  SSL_CTX_set_options(
      ctx, SSL_OP_NO_COMPRESSION | SSL_OP_NO_RENEGOTIATION | SSL_OP_CIPHER_SERVER_PREFERENCE | SSL_OP_NO_TICKET);
  // No resumption: sessions are long and few, and a TLS 1.3 ticket arriving after the handshake would be the only
  // bytes a client waiting for a reply sees.
  SSL_CTX_set_num_tickets(ctx, 0);
  SSL_CTX_set_session_cache_mode(ctx, SSL_SESS_CACHE_OFF);
  if (SSL_CTX_use_certificate_chain_file(ctx, files.cert.c_str()) != 1)
    tlsFail("tls.cert '" + files.cert.string() + "' is not a PEM certificate chain: " + openSslErrors("unreadable"));
  {
    std::unique_ptr<FILE, decltype(&std::fclose)> file(std::fopen(files.key.c_str(), "r"), &std::fclose);
    if (!file) tlsFail("tls.key '" + files.key.string() + "' cannot be read: " + std::strerror(errno));
    // No passphrase callback: an encrypted key fails here instead of asking a terminal.
    std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)> key(
        PEM_read_PrivateKey(
            file.get(), nullptr, [](char*, int, int, void*) { return 0; }, nullptr),
        &EVP_PKEY_free);
    if (!key)
      tlsFail("tls.key '" + files.key.string() +
           "' is not an unencrypted PEM private key: " + openSslErrors("unreadable"));
    if (EVP_PKEY_eq(X509_get0_pubkey(SSL_CTX_get0_certificate(ctx)), key.get()) != 1)
      tlsFail("tls.key '" + files.key.string() + "' does not belong to the certificate of tls.cert '" +
           files.cert.string() + "'");
    if (SSL_CTX_use_PrivateKey(ctx, key.get()) != 1 || SSL_CTX_check_private_key(ctx) != 1)
      tlsFail("tls.key '" + files.key.string() + "' cannot be used: " + openSslErrors("unknown failure"));
  }
  if (!files.ca.empty()) {
    if (SSL_CTX_load_verify_locations(ctx, files.ca.c_str(), nullptr) != 1)
      tlsFail("tls.ca '" + files.ca.string() + "' is not a PEM file of certificates: " + openSslErrors("unreadable"));
    STACK_OF(X509_NAME)* names = SSL_load_client_CA_file(files.ca.c_str());
    if (names) SSL_CTX_set_client_CA_list(ctx, names);
    SSL_CTX_set_verify(ctx, SSL_VERIFY_PEER | SSL_VERIFY_FAIL_IF_NO_PEER_CERT, nullptr);
  }
  return context;
}

TlsContexts::TlsContexts(TlsFiles files) : mFiles(std::move(files)), mCurrent(makeServerTlsContext(mFiles)) {}

std::shared_ptr<ssl::context> TlsContexts::current() const {
  std::lock_guard lock(mMutex);
  return mCurrent;
}

void TlsContexts::reload() {
  auto next = makeServerTlsContext(mFiles);  // throws, and the current one stays
  std::lock_guard lock(mMutex);
  mCurrent = std::move(next);
}

std::string tlsFailureText(const boost::system::error_code& ec) {
  // Asio's SSL category gives OpenSSL's reason ("unsupported protocol", "no shared cipher", "wrong version number",
  // "http request"); the others their own text ("stream truncated", "End of file").
  return ec.message();
}

}  // namespace voxbrick::server
