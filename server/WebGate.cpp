// HTTP decisions of the browser transport: embedded files by name, the presets and the metrics, Origin and token
// checks.
#include "server/WebGate.h"

#include <algorithm>
#include <cctype>
#include <stdexcept>

#include "server/Metrics.h"
#include "server/WebFiles.h"

namespace voxbrick::server {
namespace {

std::string lower(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = char(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

int defaultPort(const std::string& scheme) { return scheme == "https" ? 443 : 80; }

/// `text` ("host", "host:port", "[v6]:port") split into a lower-case host and a port (`fallback` when absent);
/// nullopt if the port is not a number in range or the host is empty.
std::optional<std::pair<std::string, int>> hostAndPort(std::string_view text, int fallback) {
  std::string_view host = text;
  int port = fallback;
  const size_t bracket = text.rfind(']');
  const size_t colon = text.rfind(':');
  if (colon != std::string_view::npos && (bracket == std::string_view::npos || colon > bracket)) {
    const std::string_view digits = text.substr(colon + 1);
    if (digits.empty() || digits.size() > 5 ||
        !std::all_of(digits.begin(), digits.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
      return std::nullopt;
    port = std::stoi(std::string(digits));
    if (port < 1 || port > 65535) return std::nullopt;
    host = text.substr(0, colon);
  }
  if (host.empty()) return std::nullopt;
  return std::make_pair(lower(host), port);
}

/// The path of a request target (before '?'), and its query (after it; empty if none).
std::pair<std::string_view, std::string_view> splitTarget(std::string_view target) {
  const size_t q = target.find('?');
  if (q == std::string_view::npos) return {target, {}};
  return {target.substr(0, q), target.substr(q + 1)};
}

/// The value of `name` in a query string (a=b&c=d); nullopt if absent.
std::optional<std::string_view> queryValue(std::string_view query, std::string_view name) {
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    const size_t eq = pair.find('=');
    if (pair.substr(0, eq) == name) return eq == std::string_view::npos ? std::string_view() : pair.substr(eq + 1);
    if (amp == std::string_view::npos) break;
    query.remove_prefix(amp + 1);
  }
  return std::nullopt;
}

/// The credentials of an Authorization header of the Bearer scheme (RFC 6750; the scheme's name in any case), or
/// nullopt for another scheme or none.
std::optional<std::string_view> bearerToken(std::string_view authorization) {
  constexpr std::string_view kScheme = "bearer ";
  if (authorization.size() <= kScheme.size() || lower(authorization.substr(0, kScheme.size())) != kScheme)
    return std::nullopt;
  std::string_view token = authorization.substr(kScheme.size());
  while (!token.empty() && token.front() == ' ') token.remove_prefix(1);
  while (!token.empty() && token.back() == ' ') token.remove_suffix(1);
  return token;
}

WebGate::Response textResponse(int status, std::string text) {
  WebGate::Response r;
  r.status = status;
  r.contentType = "text/plain; charset=utf-8";
  r.text = std::move(text) + "\n";
  return r;
}

}  // namespace

std::optional<WebGate::Origin> WebGate::parseOrigin(std::string_view text) {
  const size_t sep = text.find("://");
  if (sep == std::string_view::npos) return std::nullopt;
  Origin origin;
  origin.scheme = lower(text.substr(0, sep));
  if (origin.scheme != "http" && origin.scheme != "https") return std::nullopt;
  std::string_view rest = text.substr(sep + 3);
  if (!rest.empty() && rest.back() == '/') rest.remove_suffix(1);
  if (rest.find_first_of("/?#@ ") != std::string_view::npos) return std::nullopt;
  const auto hp = hostAndPort(rest, defaultPort(origin.scheme));
  if (!hp) return std::nullopt;
  origin.host = hp->first;
  origin.port = hp->second;
  return origin;
}

bool WebGate::validToken(std::string_view token) {
  return !token.empty() && std::all_of(token.begin(), token.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '.' || c == '_' || c == '~';
  });
}

namespace {

std::shared_ptr<const AccessTokens> singleToken(const std::string& token) {
  ServerConfig config;
  config.httpToken = token;
  return std::make_shared<const AccessTokens>(config);
}

}  // namespace

WebGate::WebGate(const std::vector<std::string>& origins, const std::string& token, std::string presetsJson,
                 std::function<std::string()> metrics)
    : WebGate(origins, singleToken(token), std::move(presetsJson), std::move(metrics)) {}

WebGate::WebGate(const std::vector<std::string>& origins, std::shared_ptr<const AccessTokens> tokens,
                 std::string presetsJson, std::function<std::string()> metrics)
    : mTokens(std::move(tokens)), mPresetsJson(std::move(presetsJson)), mMetrics(std::move(metrics)) {
  for (const std::string& text : origins) {
    const auto origin = parseOrigin(text);
    if (!origin) throw std::invalid_argument("'" + text + "' is not an origin (scheme://host[:port])");
    mOrigins.push_back(*origin);
  }
}

bool WebGate::isSocketPath(std::string_view target) { return splitTarget(target).first == "/ws"; }

WebGate::Response WebGate::respond(std::string_view method, std::string_view target, std::string_view ifNoneMatch,
                                   std::string_view origin, std::string_view authorization) const {
  if (method != "GET" && method != "HEAD") {
    Response r = textResponse(405, "method not allowed: only GET and HEAD are served");
    return r;
  }
  const std::string_view path = splitTarget(target).first;
  if (path == "/ws") {
    // The token is checked here too, so a page that probes /ws learns why it would be refused.
    if (const auto refusal = tokenRefusal(target)) return textResponse(403, "forbidden: " + *refusal);
    return textResponse(426, "/ws is the WebSocket endpoint: open it with a WebSocket upgrade");
  }
  if (path == "/presets.json") {
    if (const auto refusal = tokenRefusal(target, authorization)) return textResponse(403, "forbidden: " + *refusal);
    Response r;
    r.contentType = "application/json";
    r.body = {reinterpret_cast<const uint8_t*>(mPresetsJson.data()), mPresetsJson.size()};
    r.allowOrigin = allowedOrigin(origin);
    return r;
  }
  if (path == "/metrics" && mMetrics) {
    std::shared_ptr<const TokenGrant> grant;
    if (const auto refusal = tokenRefusal(target, authorization, &grant))
      return textResponse(403, "forbidden: " + *refusal);
    // The metrics name every open dataset: a token that may see only some of them may not read them.
    if (grant && !grant->everything())
      return textResponse(403, "forbidden: token '" + grant->id +
                                   "' may not read the metrics, which name every dataset: use one whose datasets "
                                   "are [\"*\"]");
    Response r;
    r.contentType = kMetricsContentType;
    r.text = mMetrics();
    r.allowOrigin = allowedOrigin(origin);
    return r;
  }
  // Only the embedded files' own names match: a path that climbs (..), is escaped (%2e) or absolute-form names none.
  const WebFile* file = path == "/"                              ? findWebFile("index.html")
                        : path.size() > 1 && path.front() == '/' ? findWebFile(path.substr(1))
                                                                 : nullptr;
  if (!file) return textResponse(404, "not found");
  Response r;
  r.contentType = file->contentType;
  r.body = file->bytes;
  r.etag = file->etag;
  r.notModified = !ifNoneMatch.empty() && ifNoneMatch == file->etag;
  if (r.notModified) r.status = 304;
  return r;
}

std::optional<std::string> WebGate::refuseUpgrade(std::string_view target, std::optional<std::string_view> origin,
                                                  std::string_view host) const {
  if (!isSocketPath(target)) return "no WebSocket endpoint at this path (it is /ws)";
  if (origin) {
    const auto seen = parseOrigin(*origin);
    if (!seen) return "Origin '" + std::string(*origin) + "' is not allowed";
    const auto own = hostAndPort(host, defaultPort(seen->scheme));
    const bool sameOrigin = own && own->first == seen->host && own->second == seen->port;
    if (!sameOrigin && std::find(mOrigins.begin(), mOrigins.end(), *seen) == mOrigins.end())
      return "Origin '" + std::string(*origin) + "' is not allowed (only this server's own pages, and the origins " +
             "configured in http.origins, may open /ws)";
  }
  return tokenRefusal(target);
}

std::optional<std::string> WebGate::tokenRefusal(std::string_view target, std::string_view authorization,
                                                 std::shared_ptr<const TokenGrant>* grant) const {
  if (!mTokens->configured()) return std::nullopt;
  auto given = queryValue(splitTarget(target).second, "token");
  if (!given) given = bearerToken(authorization);
  if (!given)
    return "an access token is required (open the page with ?token=TOKEN added to its address, or send "
           "Authorization: Bearer TOKEN)";
  auto matched = mTokens->match(*given);
  if (!matched) return "wrong access token";
  if (grant) *grant = std::move(matched);
  return std::nullopt;
}

std::shared_ptr<const TokenGrant> WebGate::acceptedToken(std::string_view target) const {
  std::shared_ptr<const TokenGrant> grant;
  return tokenRefusal(target, {}, &grant) ? nullptr : grant;
}

std::string WebGate::allowedOrigin(std::string_view origin) const {
  // A page of a configured origin (a copy of the viewer served elsewhere) may read the answer; the page's own origin
  // needs no header.
  const auto seen = parseOrigin(origin);
  return seen && std::find(mOrigins.begin(), mOrigins.end(), *seen) != mOrigins.end() ? std::string(origin) : "";
}

}  // namespace voxbrick::server
