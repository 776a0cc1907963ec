// HTTP(S) GETs for DICOMweb through libcurl (private to this folder): certificates checked, credentials kept out of
// every message, time limits, and retries with back-off for what a retry can mend (5xx, a refused or cut connection).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {

/// Credentials for a DICOMweb server, from a file or the environment; never from the command line.
struct HttpCredentials {
  enum class Scheme { None, Basic, Bearer };
  Scheme scheme = Scheme::None;
  std::string user;    ///< Basic: the user name
  std::string secret;  ///< Basic: the password; Bearer: the token. Never part of a message.
  std::string origin;  ///< where they came from, for messages: "--auth-file FILE", "VOXBRICK_DICOMWEB_AUTH"
};

/// The environment variable that holds credentials when no file is named: "basic USER:PASSWORD" or "bearer TOKEN".
inline constexpr const char* kDicomWebAuthVariable = "VOXBRICK_DICOMWEB_AUTH";

/// The credentials in `authFile` (its first line that is not empty), else in kDicomWebAuthVariable, else none. The
/// text is "basic USER:PASSWORD" or "bearer TOKEN" (the scheme in any case). Throws InputError naming the file or
/// variable (never its content) when it cannot be read or is not of that form.
HttpCredentials readHttpCredentials(const std::string& authFile);

/// How requests are made.
struct HttpOptions {
  std::string caFile;               ///< PEM certificates to trust for HTTPS; "" for the system's store
  HttpCredentials credentials;      ///< sent with every request (Basic or Bearer)
  double timeoutSeconds = 30;       ///< to connect, and the longest a transfer may receive nothing
  int retries = 3;                  ///< further attempts of a request that failed in a way a retry may mend
  double retryDelaySeconds = 0.5;   ///< before the first retry; doubled for each next one, at most 8 s
  int64_t maxBytesPerSecond = 0;    ///< each transfer's receive rate limit; 0 for none
  std::function<bool()> cancelled;  ///< polled during transfers and waits; true stops with "interrupted"
};

/// A request that failed: the message names the method, the URL and the HTTP status or the connection's fault.
class HttpError : public InputError {
 public:
  HttpError(const std::string& message, long status, bool retryable)
      : InputError(message), mStatus(status), mRetryable(retryable) {}
  /// The HTTP status; 0 when no response came (connection, TLS, a transfer cut).
  long status() const { return mStatus; }
  /// Whether another attempt may succeed (5xx, refused, timed out, cut).
  bool retryable() const { return mRetryable; }

 private:
  long mStatus;
  bool mRetryable;
};

/// Receives a successful (2xx) response's body. An attempt that fails after begin() is abandoned before a retry;
/// a handler's exception stops the request and passes out of HttpClient::get (a MultipartError marked truncated
/// counts as a transfer cut, which is retried).
class ResponseHandler {
 public:
  virtual ~ResponseHandler() = default;
  /// The response is a success; its Content-Type ("" when absent). Called before any body byte, once an attempt.
  virtual void begin(const std::string& contentType) = 0;
  /// The next bytes of the body.
  virtual void data(const char* bytes, size_t size) = 0;
  /// The body is complete.
  virtual void end() = 0;
  /// The attempt failed after begin(): undo what it did (a retry starts over).
  virtual void abandon() {}
};

/// One connection's worth of requests (libcurl's easy handle: kept-alive connections are reused). Not thread-safe:
/// one a thread.
class HttpClient {
 public:
  explicit HttpClient(HttpOptions options);
  ~HttpClient();
  HttpClient(const HttpClient&) = delete;
  HttpClient& operator=(const HttpClient&) = delete;

  /// GETs `url` with the Accept header `accept` and hands a 2xx body to `handler`, retrying as HttpOptions says.
  /// Throws HttpError ("GET URL: ..."), StoreError("interrupted; nothing was written") when cancelled, or the
  /// handler's own exception.
  void get(const std::string& url, const std::string& accept, ResponseHandler& handler);

  /// The body bytes received by every request so far (a retried one's counted again).
  uint64_t bytesReceived() const;

  /// The Warning headers of the last response, one a line ("" when none): how a DICOMweb server says that it cut a
  /// search's results short (299 "The number of results exceeded the maximum supported by the server").
  const std::string& warning() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> mImpl;
};

}  // namespace voxbrick::store
