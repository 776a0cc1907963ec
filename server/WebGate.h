// What the HTTP side of the browser transport decides, without sockets: which embedded file (or error) answers a
// plain request, the presets and the metrics behind the access token, and whether a WebSocket upgrade of /ws may
// proceed (its Origin and its access token).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "server/AccessTokens.h"

namespace voxbrick::server {

class WebGate {
 public:
  /// An origin as browsers send it in the Origin header: scheme, host and port (the scheme's default port when the
  /// text names none); compared case-insensitively on scheme and host.
  struct Origin {
    std::string scheme, host;
    int port = 0;
    friend bool operator==(const Origin&, const Origin&) = default;
  };
  /// The origin `text` names (scheme://host[:port], scheme http or https, nothing after it but an optional '/');
  /// nullopt if it is not one.
  static std::optional<Origin> parseOrigin(std::string_view text);
  /// Whether `token` may be an access token: letters, digits and - . _ ~ (so it travels in a URL unescaped).
  static bool validToken(std::string_view token);

  /// `origins`: the configured origins allowed besides the page's own (each as parseOrigin reads it; throws
  /// std::invalid_argument for one that is not); `tokens`: the access tokens, of which /ws, /presets.json and
  /// /metrics must carry one when any is configured (/metrics one that opens every dataset, since it names them
  /// all); `presetsJson`: the body of /presets.json, the server's transfer-function presets with their curves
  /// (TransferFunctionPresets::json without files), which the page draws in its curve editor; `metrics`: makes the
  /// body of /metrics, the server's statistics in Prometheus' text format (none: /metrics is 404). It is called on
  /// the I/O thread that answers the request and must be thread-safe.
  WebGate(const std::vector<std::string>& origins, std::shared_ptr<const AccessTokens> tokens,
          std::string presetsJson = "[]", std::function<std::string()> metrics = {});
  /// The same with the single access token `token` (http.token; empty: none) as the only one.
  WebGate(const std::vector<std::string>& origins, const std::string& token, std::string presetsJson = "[]",
          std::function<std::string()> metrics = {});

  /// The answer to a request that is not an upgrade.
  struct Response {
    int status = 200;
    std::string_view contentType;
    std::span<const uint8_t> body;  ///< an embedded file's bytes (status 200)
    std::string text;               ///< the body of an error
    std::string etag;               ///< of a file, empty otherwise
    bool notModified = false;       ///< 304: the client holds the file with this etag already
    std::string allowOrigin;        ///< Access-Control-Allow-Origin to send (a configured origin), empty for none
  };
  /// The answer to `method` `target` (the request line's target) with `ifNoneMatch` (the header, possibly empty):
  /// an embedded file for GET and HEAD ("/" is index.html; the query is ignored), 404 for any path that names none,
  /// 405 for other methods, 426 for /ws without an upgrade (403 naming why when its token is missing or wrong).
  /// /presets.json is the presets' JSON and /metrics the metrics' text, both behind the same token as /ws, given in
  /// the query (?token=) or as `authorization` (the Authorization header, "Bearer TOKEN", as Prometheus sends it);
  /// for a request whose `origin` (the Origin header, empty when absent) is a configured one, they may be read by
  /// that origin's pages (allowOrigin).
  Response respond(std::string_view method, std::string_view target, std::string_view ifNoneMatch,
                   std::string_view origin = {}, std::string_view authorization = {}) const;

  /// Whether `target` names the WebSocket endpoint (/ws, with any query).
  static bool isSocketPath(std::string_view target);
  /// Why an upgrade of `target` from `origin` (nullopt: the request had no Origin header, as non-browser clients
  /// send) with Host header `host` is refused, or nullopt if it may proceed: the Origin must be the page's own (its
  /// host and port equal to Host) or a configured one, and with a token set the target must carry ?token=<it>.
  std::optional<std::string> refuseUpgrade(std::string_view target, std::optional<std::string_view> origin,
                                           std::string_view host) const;

  /// The grant of the access token `target` carries (what the session may see, what its quotas count), or null when
  /// it carries none that matches.
  std::shared_ptr<const TokenGrant> acceptedToken(std::string_view target) const;

 private:
  /// Why `target` fails the access tokens (missing, wrong), or nullopt when none is configured or it carries one:
  /// the query's token, else the Bearer token of `authorization` (the Authorization header; empty when absent).
  /// `grant`, if given, receives the token's grant.
  std::optional<std::string> tokenRefusal(std::string_view target, std::string_view authorization = {},
                                          std::shared_ptr<const TokenGrant>* grant = nullptr) const;
  /// Access-Control-Allow-Origin for a request from `origin`: itself when it is a configured origin, else empty.
  std::string allowedOrigin(std::string_view origin) const;

  std::vector<Origin> mOrigins;
  std::shared_ptr<const AccessTokens> mTokens;
  std::string mPresetsJson;
  std::function<std::string()> mMetrics;
};

}  // namespace voxbrick::server
