// DICOMweb's GETs through libcurl: one easy handle a client, errors named by status or connection fault, retries.
#include "brickstore/ingest/dicomweb/HttpClient.h"

#include <curl/curl.h>
#include <dlfcn.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>
#include <type_traits>

#include "brickstore/ingest/dicomweb/Multipart.h"

namespace voxbrick::store {
namespace {

/// `message` without curl's timings ("after 4 ms" becomes "after ms"): two attempts that failed alike read alike.
std::string withoutTimings(std::string message) {
  for (size_t at = message.find("after "); at != std::string::npos; at = message.find("after ", at + 1)) {
    size_t end = at + 6;
    while (end < message.size() && std::isdigit(static_cast<unsigned char>(message[end]))) ++end;
    if (end > at + 6 && message.compare(end, 3, " ms") == 0) message.erase(at + 6, end - (at + 6) + 1);
  }
  return message;
}

// libcurl is loaded the first time a transfer is made (dlopen), not linked: a process that fetches nothing does not
// load it and the two dozen libraries it needs, a third of the start of a command that needs neither OpenVDB nor GDCM
// (docs/design/modules.md). The functions below, named as libcurl's, stand in for them in this file (its unqualified
// calls, curl's own type-checking macros included, find these first) and call the library's; the two whose argument
// is one of curl's own types (CURLcode, curl_slist), which argument-dependent lookup would find too, are called
// through curlLibrary() by name.
constexpr char kCurlLibrary[] = "libcurl.so.4";

struct CurlLibrary {
  decltype(&::curl_global_init) globalInit;
  decltype(&::curl_easy_init) easyInit;
  decltype(&::curl_easy_setopt) easySetopt;
  decltype(&::curl_easy_perform) easyPerform;
  decltype(&::curl_easy_getinfo) easyGetinfo;
  decltype(&::curl_easy_cleanup) easyCleanup;
  decltype(&::curl_easy_strerror) easyStrerror;
  decltype(&::curl_slist_append) slistAppend;
  decltype(&::curl_slist_free_all) slistFreeAll;
};

const CurlLibrary& curlLibrary() {
  static const CurlLibrary library = [] {
    ::dlerror();
    void* handle = ::dlopen(kCurlLibrary, RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* why = ::dlerror();
      throw StoreError(std::string("DICOMweb needs libcurl, and ") + kCurlLibrary + " could not be loaded (" +
                       (why ? why : "not found") + "; Debian's package libcurl4)");
    }
    CurlLibrary l{};
    auto resolve = [&](auto& function, const char* name) {
      function = reinterpret_cast<std::remove_reference_t<decltype(function)>>(::dlsym(handle, name));
      if (function == nullptr) throw StoreError(std::string(kCurlLibrary) + " has no " + name);
    };
    resolve(l.globalInit, "curl_global_init");
    resolve(l.easyInit, "curl_easy_init");
    resolve(l.easySetopt, "curl_easy_setopt");
    resolve(l.easyPerform, "curl_easy_perform");
    resolve(l.easyGetinfo, "curl_easy_getinfo");
    resolve(l.easyCleanup, "curl_easy_cleanup");
    resolve(l.easyStrerror, "curl_easy_strerror");
    resolve(l.slistAppend, "curl_slist_append");
    resolve(l.slistFreeAll, "curl_slist_free_all");
    return l;
  }();
  return library;
}

CURLcode curl_global_init(long flags) { return curlLibrary().globalInit(flags); }
CURL* curl_easy_init() { return curlLibrary().easyInit(); }
// In parentheses: curl/curl.h makes curl_easy_setopt and curl_easy_getinfo macros that check the argument's type.
template <class Value>
CURLcode(curl_easy_setopt)(CURL* curl, CURLoption option, Value value) {
  return curlLibrary().easySetopt(curl, option, value);
}
CURLcode curl_easy_perform(CURL* curl) { return curlLibrary().easyPerform(curl); }
template <class Out>
CURLcode(curl_easy_getinfo)(CURL* curl, CURLINFO info, Out out) {
  return curlLibrary().easyGetinfo(curl, info, out);
}
void curl_easy_cleanup(CURL* curl) { curlLibrary().easyCleanup(curl); }
curl_slist* curl_slist_append(curl_slist* list, const char* text) { return curlLibrary().slistAppend(list, text); }

constexpr size_t kErrorBodyBytes = 4096;  // of a failed response's body, kept for its message
constexpr double kMaxRetryDelay = 8.0;

const char* reasonPhrase(long status) {
  switch (status) {
    case 400: return "Bad Request";
    case 401: return "Unauthorized";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 406: return "Not Acceptable";
    case 408: return "Request Timeout";
    case 410: return "Gone";
    case 413: return "Content Too Large";
    case 415: return "Unsupported Media Type";
    case 429: return "Too Many Requests";
    case 500: return "Internal Server Error";
    case 501: return "Not Implemented";
    case 502: return "Bad Gateway";
    case 503: return "Service Unavailable";
    case 504: return "Gateway Timeout";
    default: return "";
  }
}

std::string trimmed(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  size_t start = 0;
  while (start < s.size() && std::isspace(static_cast<unsigned char>(s[start]))) ++start;
  return s.substr(start);
}

/// Printable ASCII of at most `max` characters: what a server wrote is shown, never trusted to be text.
std::string printable(const std::string& s, size_t max = 160) {
  std::string out;
  for (char c : s) {
    if (out.size() >= max) {
      out += "...";
      break;
    }
    const unsigned char u = static_cast<unsigned char>(c);
    out += (u >= 0x20 && u < 0x7f) ? c : ' ';
  }
  return trimmed(out);
}

/// What a failed response's body says, when it says something short: a JSON error's Details or Message (Orthanc,
/// and others), else the first line of a text body.
std::string serverSays(const std::string& body, const std::string& contentType) {
  if (body.empty()) return "";
  const std::string type = contentType.substr(0, contentType.find(';'));
  if (type.find("json") != std::string::npos || body.front() == '{') {
    const nlohmann::json j = nlohmann::json::parse(body, nullptr, false);
    if (j.is_object())
      for (const char* key : {"Details", "Message", "message", "error", "Error"})
        if (j.contains(key) && j[key].is_string() && !j[key].get<std::string>().empty())
          return printable(j[key].get<std::string>());
    return "";
  }
  if (type.rfind("text/", 0) != 0 || type == "text/html") return "";
  return printable(body.substr(0, body.find('\n')));
}

std::string byteText(uint64_t bytes) {
  if (bytes < 10000) return std::to_string(bytes) + " bytes";
  char text[32];
  std::snprintf(text, sizeof text, bytes < 10000000 ? "%.1f kB" : "%.1f MB",
                bytes < 10000000 ? bytes / 1e3 : bytes / 1e6);
  return text;
}

void initialiseCurl() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK) throw StoreError("libcurl could not be initialised");
  });
}

std::string lowerHeader(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

}  // namespace

HttpCredentials readHttpCredentials(const std::string& authFile) {
  HttpCredentials c;
  std::string text;
  if (!authFile.empty()) {
    c.origin = "--auth-file " + authFile;
    std::ifstream in(authFile, std::ios::binary);
    if (!in) throw InputError(authFile + ": cannot read the credentials file (--auth-file): " + std::strerror(errno));
    std::string line;
    for (int n = 0; n < 64 && std::getline(in, line); ++n) {
      line = trimmed(line);
      if (!line.empty()) break;
    }
    text = line;
  } else if (const char* value = std::getenv(kDicomWebAuthVariable); value != nullptr && *value != '\0') {
    c.origin = kDicomWebAuthVariable;
    text = trimmed(value);
  } else {
    return c;
  }
  const size_t space = text.find_first_of(" \t");
  const std::string scheme = lowerHeader(text.substr(0, space));
  const std::string rest = space == std::string::npos ? "" : trimmed(text.substr(space));
  if (scheme == "basic" && rest.find(':') != std::string::npos && rest.find(':') > 0) {
    c.scheme = HttpCredentials::Scheme::Basic;
    c.user = rest.substr(0, rest.find(':'));
    c.secret = rest.substr(rest.find(':') + 1);
  } else if (scheme == "bearer" && !rest.empty() && rest.find_first_of(" \t") == std::string::npos) {
    c.scheme = HttpCredentials::Scheme::Bearer;
    c.secret = rest;
  } else {
    throw InputError(c.origin + ": expected 'basic USER:PASSWORD' or 'bearer TOKEN'" +
                     (authFile.empty() ? "" : " on the file's first line"));
  }
  return c;
}

struct HttpClient::Impl {
  HttpOptions options;
  CURL* curl = nullptr;
  uint64_t received = 0;
  char errorText[CURL_ERROR_SIZE] = {};

  // One attempt's state.
  ResponseHandler* handler = nullptr;
  bool begun = false;
  bool interrupted = false;
  long status = 0;
  std::string contentType, errorBody;
  std::string warning;  // the response's Warning headers, one a line
  int64_t contentLength = -1;
  std::exception_ptr handlerError;

  static size_t onHeader(char* data, size_t size, size_t count, void* self) {
    auto& impl = *static_cast<Impl*>(self);
    const std::string line(data, size * count);
    if (line.rfind("HTTP/", 0) == 0) {  // a new response (after a redirect or a 100 Continue): its own headers
      impl.contentType.clear();
      impl.warning.clear();
      impl.contentLength = -1;
    }
    const size_t colon = line.find(':');
    if (colon != std::string::npos) {
      const std::string name = lowerHeader(line.substr(0, colon));
      const std::string value = trimmed(line.substr(colon + 1));
      if (name == "content-type") impl.contentType = value;
      if (name == "warning" && impl.warning.size() < kErrorBodyBytes) impl.warning += value + "\n";
      if (name == "content-length" && !value.empty() && value.size() < 19 &&
          std::all_of(value.begin(), value.end(), [](char c) { return c >= '0' && c <= '9'; }))
        impl.contentLength = std::stoll(value);
    }
    return size * count;
  }

  static size_t onBody(char* data, size_t size, size_t count, void* self) {
    auto& impl = *static_cast<Impl*>(self);
    const size_t bytes = size * count;
    impl.received += bytes;
    try {
      if (!impl.begun) {
        curl_easy_getinfo(impl.curl, CURLINFO_RESPONSE_CODE, &impl.status);
        if (impl.status >= 200 && impl.status < 300) {
          impl.begun = true;
          impl.handler->begin(impl.contentType);
        }
      }
      if (impl.begun) {
        if (bytes > 0) impl.handler->data(data, bytes);
      } else if (impl.errorBody.size() < kErrorBodyBytes) {
        impl.errorBody.append(data, std::min(bytes, kErrorBodyBytes - impl.errorBody.size()));
      }
    } catch (...) {
      impl.handlerError = std::current_exception();
      return bytes == 0 ? 1 : 0;  // a count that differs from `bytes` stops the transfer
    }
    return bytes;
  }

  static int onProgress(void* self, curl_off_t, curl_off_t, curl_off_t, curl_off_t) {
    auto& impl = *static_cast<Impl*>(self);
    if (impl.options.cancelled && impl.options.cancelled()) {
      impl.interrupted = true;
      return 1;
    }
    return 0;
  }

  [[noreturn]] void throwInterrupted() { throw StoreError("interrupted; nothing was written"); }

  /// The message of a transfer that failed in libcurl, and whether a retry may mend it.
  HttpError transferError(const std::string& url, CURLcode rc) const {
    const std::string detail = errorText[0] ? std::string(errorText) : curlLibrary().easyStrerror(rc);
    const std::string prefix = "GET " + url + ": ";
    long osErrno = 0;
    curl_easy_getinfo(curl, CURLINFO_OS_ERRNO, &osErrno);
    // The bytes as they came (compressed, when the server compressed them), as Content-Length counts them.
    curl_off_t wireBytes = 0;
    curl_easy_getinfo(curl, CURLINFO_SIZE_DOWNLOAD_T, &wireBytes);
    const uint64_t got = uint64_t(std::max<curl_off_t>(0, wireBytes));
    switch (rc) {
      case CURLE_COULDNT_CONNECT:
        return HttpError(
            prefix + (osErrno == ECONNREFUSED ? "connection refused" : "cannot connect") + " (" + detail + ")", 0,
            true);
      case CURLE_COULDNT_RESOLVE_HOST: return HttpError(prefix + "unknown host (" + detail + ")", 0, false);
      case CURLE_OPERATION_TIMEDOUT:
        return HttpError(
            prefix + (got > 0 ? "the transfer stalled after " + byteText(got) + " (" : "no answer (") + detail + ")", 0,
            true);
      case CURLE_PARTIAL_FILE:
      case CURLE_RECV_ERROR:
      case CURLE_SEND_ERROR:
      case CURLE_GOT_NOTHING:
      case CURLE_HTTP2:
      case CURLE_HTTP2_STREAM:
        return HttpError(prefix + "the transfer was cut after " + byteText(got) +
                             (contentLength >= 0 ? " of " + byteText(uint64_t(contentLength)) : "") + " (" + detail +
                             ")",
                         0, true);
      case CURLE_PEER_FAILED_VERIFICATION:
        return HttpError(
            prefix + "the server's TLS certificate is not trusted (" + detail + ")" +
                (options.caFile.empty() ? "; give the certificate of the authority that signed it with --ca FILE"
                                        : "; it is not signed by --ca " + options.caFile),
            0, false);
      case CURLE_SSL_CACERT_BADFILE:
        return HttpError(prefix + "--ca " + options.caFile + " cannot be read as PEM certificates (" + detail + ")", 0,
                         false);
      case CURLE_TOO_MANY_REDIRECTS: return HttpError(prefix + "too many redirects (" + detail + ")", 0, false);
      case CURLE_UNSUPPORTED_PROTOCOL:
        return HttpError(prefix + "redirected to a scheme not allowed here (" + detail + ")", 0, false);
      default: return HttpError(prefix + detail, 0, false);
    }
  }

  /// The message of a response whose status is not 2xx; 5xx may be mended by a retry.
  HttpError statusError(const std::string& url) const {
    std::string message = "GET " + url + ": HTTP " + std::to_string(status);
    if (*reasonPhrase(status)) message += std::string(" ") + reasonPhrase(status);
    const HttpCredentials& c = options.credentials;
    if (status == 401)
      message += c.scheme == HttpCredentials::Scheme::None
                     ? ": the server asks for credentials; give them in a file (--auth-file FILE) or in " +
                           std::string(kDicomWebAuthVariable) + " ('basic USER:PASSWORD' or 'bearer TOKEN')"
                     : ": the server refused the credentials from " + c.origin + " (wrong user, password or token)";
    else if (status == 403)
      message += c.scheme == HttpCredentials::Scheme::None
                     ? ": the server refuses this without credentials"
                     : ": the credentials from " + c.origin + " are not allowed this resource";
    const std::string says = serverSays(errorBody, contentType);
    if (!says.empty()) message += " (the server says: " + says + ")";
    return HttpError(message, status, status >= 500 || status == 408 || status == 429);
  }

  void attempt(const std::string& url, const std::string& accept, ResponseHandler& h) {
    handler = &h;
    begun = interrupted = false;
    status = 0;
    contentType.clear();
    errorBody.clear();
    warning.clear();
    contentLength = -1;
    handlerError = nullptr;
    errorText[0] = '\0';

    const std::string acceptHeader = "Accept: " + accept;
    curl_slist* headers = curl_slist_append(nullptr, acceptHeader.c_str());
    curl_easy_setopt(curl, CURLOPT_URL, url.c_str());
    curl_easy_setopt(curl, CURLOPT_HTTPHEADER, headers);
    // A redirect may not leave HTTPS for plain HTTP.
    curl_easy_setopt(curl, CURLOPT_REDIR_PROTOCOLS_STR, url.rfind("https:", 0) == 0 ? "https" : "http,https");
    const CURLcode rc = curl_easy_perform(curl);
    curlLibrary().slistFreeAll(headers);
    curl_easy_getinfo(curl, CURLINFO_RESPONSE_CODE, &status);

    try {
      if (handlerError) std::rethrow_exception(handlerError);
      if (interrupted) throwInterrupted();
      if (rc != CURLE_OK) throw transferError(url, rc);
      if (status < 200 || status >= 300) throw statusError(url);
      if (!begun) {
        begun = true;
        h.begin(contentType);
      }
      h.end();
    } catch (const MultipartError& e) {
      if (begun) h.abandon();
      if (!e.truncated()) throw HttpError("GET " + url + ": " + e.what(), status, false);
      throw HttpError("GET " + url + ": the transfer was cut (" + e.what() + ")", status, true);
    } catch (...) {
      if (begun) h.abandon();
      throw;
    }
  }

  /// Sleeps `seconds` unless cancelled first.
  void pause(double seconds) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < until) {
      if (options.cancelled && options.cancelled()) throwInterrupted();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
};

HttpClient::HttpClient(HttpOptions options) : mImpl(std::make_unique<Impl>()) {
  initialiseCurl();
  Impl& m = *mImpl;
  m.options = std::move(options);
  m.curl = curl_easy_init();
  if (m.curl == nullptr) throw StoreError("libcurl could not make a transfer handle");
  CURL* c = m.curl;
  const long timeoutMs = std::lround(std::max(0.001, m.options.timeoutSeconds) * 1000);
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
  curl_easy_setopt(c, CURLOPT_ERRORBUFFER, m.errorText);
  curl_easy_setopt(c, CURLOPT_PROTOCOLS_STR, "http,https");
  curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 1L);
  curl_easy_setopt(c, CURLOPT_MAXREDIRS, 5L);
  curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT_MS, timeoutMs);
  // A transfer that receives less than a byte a second for the timeout has stalled.
  curl_easy_setopt(c, CURLOPT_LOW_SPEED_LIMIT, 1L);
  curl_easy_setopt(c, CURLOPT_LOW_SPEED_TIME, std::max(1L, long(std::ceil(m.options.timeoutSeconds))));
  curl_easy_setopt(c, CURLOPT_SSL_VERIFYPEER, 1L);
  curl_easy_setopt(c, CURLOPT_SSL_VERIFYHOST, 2L);
  if (!m.options.caFile.empty()) curl_easy_setopt(c, CURLOPT_CAINFO, m.options.caFile.c_str());
  curl_easy_setopt(c, CURLOPT_ACCEPT_ENCODING, "");
  curl_easy_setopt(c, CURLOPT_USERAGENT, "voxbrick");
  curl_easy_setopt(c, CURLOPT_TCP_KEEPALIVE, 1L);
  if (m.options.maxBytesPerSecond > 0)
    curl_easy_setopt(c, CURLOPT_MAX_RECV_SPEED_LARGE, curl_off_t(m.options.maxBytesPerSecond));
  const HttpCredentials& cred = m.options.credentials;
  if (cred.scheme == HttpCredentials::Scheme::Basic) {
    curl_easy_setopt(c, CURLOPT_HTTPAUTH, long(CURLAUTH_BASIC));
    curl_easy_setopt(c, CURLOPT_USERNAME, cred.user.c_str());
    curl_easy_setopt(c, CURLOPT_PASSWORD, cred.secret.c_str());
  } else if (cred.scheme == HttpCredentials::Scheme::Bearer) {
    curl_easy_setopt(c, CURLOPT_HTTPAUTH, long(CURLAUTH_BEARER));
    curl_easy_setopt(c, CURLOPT_XOAUTH2_BEARER, cred.secret.c_str());
  }
  curl_easy_setopt(c, CURLOPT_HEADERFUNCTION, &Impl::onHeader);
  curl_easy_setopt(c, CURLOPT_HEADERDATA, &m);
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, &Impl::onBody);
  curl_easy_setopt(c, CURLOPT_WRITEDATA, &m);
  curl_easy_setopt(c, CURLOPT_NOPROGRESS, 0L);
  curl_easy_setopt(c, CURLOPT_XFERINFOFUNCTION, &Impl::onProgress);
  curl_easy_setopt(c, CURLOPT_XFERINFODATA, &m);
}

HttpClient::~HttpClient() {
  if (mImpl && mImpl->curl) curl_easy_cleanup(mImpl->curl);
}

uint64_t HttpClient::bytesReceived() const { return mImpl->received; }

const std::string& HttpClient::warning() const { return mImpl->warning; }

void HttpClient::get(const std::string& url, const std::string& accept, ResponseHandler& handler) {
  Impl& m = *mImpl;
  std::string first;
  const int attempts = 1 + std::max(0, m.options.retries);
  double delay = m.options.retryDelaySeconds;
  for (int attempt = 1;; ++attempt) {
    if (m.options.cancelled && m.options.cancelled()) m.throwInterrupted();
    try {
      m.attempt(url, accept, handler);
      return;
    } catch (const HttpError& e) {
      if (!e.retryable() || attempt >= attempts) {
        if (attempt == 1) throw;
        std::string message = e.what();
        message += " (" + std::to_string(attempt) + " attempts";
        if (!first.empty() && withoutTimings(first) != withoutTimings(e.what()))
          message += "; the first: " + first.substr(("GET " + url + ": ").size());
        throw HttpError(message + ")", e.status(), false);
      }
      if (first.empty()) first = e.what();
    }
    m.pause(delay);
    delay = std::min(kMaxRetryDelay, delay * 2);
  }
}

}  // namespace voxbrick::store
