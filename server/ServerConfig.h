// The render service's configuration: a TOML file (config/server.toml) with command-line overrides and safe
// defaults. Every limit the server enforces lives here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "render/core/Backend.h"

namespace voxbrick::server {

/// How the render queue shares the render threads ([scheduler] in the file): fair queueing by measured device time,
/// classes, the interactive budget that follows the load, admission. docs/server.md says how each is used.
struct SchedulerConfig {
  bool coalesce = true;  ///< latest wins; off only to measure what it saves
  /// Each class's weight in the share of render time while several classes have work waiting (interactive, still,
  /// batch): 16, 3 and 1 give a moving camera 80 % of the time, a resting camera's exact frame 15 %, batch 5 %, and
  /// any class the whole of it when it is alone.
  double interactiveWeight = 16, stillWeight = 3, batchWeight = 1;
  /// The frame rate each interactive session's time budget is sized for: with N interactive sessions and T render
  /// threads, a moving camera's frame gets at most T * 1000 / (fps * N) ms (never more than its scene asks, never
  /// less than the scene's minimum, 10 ms), so quality yields to the crowd instead of latency.
  double interactiveFps = 10;
  /// The same share of the encoder threads for video streams: with N streams moving on E encoder threads, a stream
  /// whose frames take more than E * 1000 / (interactive_fps * N) ms to encode is sent smaller (VideoStream), so
  /// that a crowd of streams gets its frames smaller rather than later. Off only to measure what it does.
  bool encoderLadder = true;
  /// A video stream whose moving frames the crowd leaves drawn smaller than it is sent at the smallest size that
  /// holds the drawing (VideoStream::scaleForDrawing), not the drawing scaled up to the stream's size and encoded
  /// there. Off to measure what it does, or to keep a stream's size to its link and encoders alone.
  bool streamFollowsDrawing = true;
  /// Render threads kept for interactive frames while any session drags (with two threads or more): still and batch
  /// frames take at most the others, so a long still frame never holds every thread a viewer waits for. The encoder
  /// threads keep as many for interactive frames while those come (EncoderQueue).
  int reservedInteractiveThreads = 1;
  /// A batch Render whose expected wait (the measured cost of the work queued before it, over the threads' share for
  /// its class) exceeds this is answered Busy with that wait as its retry hint.
  double batchMaxWaitMs = 2000;
  /// Sessions dragging at once beyond which a session's first moving camera (one not dragging within the last second)
  /// is answered Busy, and it waits in line; 0: measured, as the render threads' time over min_interactive_fps frames
  /// of the measured interactive frame cost per session.
  int maxInteractiveSessions = 0;
  /// A new session is also answered Busy at Hello (and closed) while the sessions dragging fill the capacity; false:
  /// it is taken (its still frames are drawn) and waits in line at its first drag.
  bool busyAtHello = false;
  /// A session that has dragged this long without letting go, while others wait in line, has its next moving camera
  /// answered Busy: its turn is over, and it goes to the back of the line; 0: no limit, a drag holds its room until
  /// released. The drag is paused, not ended (no exact frame of its last camera). Alone, or while nobody waits, a drag
  /// is never paused. 2 s by default, from the front of bench/run_crowd_turn_length.sh (docs/performance.md): a crowd
  /// that never lets go shared among all its sessions (Jain's index 0.43 -> 0.97) at 5 % of its frames.
  double interactiveTurnS = 2;
  double minInteractiveFps = 5;  ///< the rate the measured capacity keeps for every dragging session
  /// Before the capacity is measured (a cold server, a crowd arriving at once), at most this many sessions per render
  /// thread may drag; 0: no limit until it is measured.
  int coldInteractiveSessionsPerThread = 4;
  bool shareFrames = true;       ///< sessions asking the identical frame at once get one render
  /// The JPEG quality of a provisional frame while the crowd cuts its budget (a scene's own jpeg_quality is kept).
  int loadedJpegQuality = 70;
};

/// Per-address and per-token quotas ([quotas]): 0 is no limit. A session past its sessions quota is refused at
/// Hello with LimitExceeded; a Render past its frames-per-second quota is answered Busy with the time until the
/// quota has room again. The token is the one a WebSocket session opened /ws with; TCP sessions carry none.
struct QuotaConfig {
  int sessionsPerAddress = 0;
  double framesPerSecondPerAddress = 0;
  int sessionsPerToken = 0;
  double framesPerSecondPerToken = 0;
  bool loopbackExempt = false;  ///< loopback clients are held to no quota
};

/// One access token of [[tokens]]: who it is (its id, in logs and the audit trail), the SHA-256 of its secret (the
/// secret itself is never stored), the datasets it may list and open, and its own quotas.
struct TokenConfig {
  std::string id;                         ///< letters, digits, '.', '-', '_'
  std::string sha256;                     ///< 64 hex digits: `voxbrick token` makes a secret and its hash
  std::vector<std::string> datasets;      ///< names or glob patterns (*, ?, [...]); ["*"] for every dataset
  std::optional<int> sessions;            ///< sessions it may hold at once; absent: quotas.sessions_per_token
  std::optional<double> framesPerSecond;  ///< Renders a second; absent: quotas.frames_per_s_per_token
  bool upload = false;                    ///< it may send volumes to become datasets ([upload])
};

/// Volumes clients send to become datasets ([upload]; PROTOCOL.md, Upload): off unless max_bytes is above 0, and
/// only for a session whose token may upload.
struct UploadConfig {
  uint64_t maxBytes = 0;  ///< the largest upload, in voxel bytes; 0: the server takes none
  int maxConcurrent = 1;  ///< uploads in progress at once, all sessions together (more: Busy)
};

/// A PACS whose image series the server lists as datasets ([[pacs]]; docs/server.md, "A PACS as datasets"): listed
/// by QIDO-RS, each prepped from DICOMweb when first opened and kept in the PACS cache.
struct PacsConfig {
  std::string id;                  ///< letters, digits, '-', '_': its series are the datasets "ID.SERIESUID"
  std::string url;                 ///< its DICOMweb root: http[s]://HOST[:PORT]/PATH (no credentials, no query)
  std::filesystem::path authFile;  ///< "basic USER:PASSWORD" or "bearer TOKEN", as prep's --auth-file; none: empty
  std::filesystem::path ca;        ///< PEM certificates to trust for https; empty: the system's
  bool patientFields = false;      ///< list each series' patient's name, id and birth date (else never shown)
  double refreshS = 60;            ///< seconds between listings of its series
};

/// Where PACS series are kept once prepped ([pacs_cache]), least recently opened evicted first.
struct PacsCacheConfig {
  std::filesystem::path dir;  ///< empty: DATASETS/.pacs (hidden: never a dataset of the folder itself)
  int64_t maxMB = 10240;      ///< the stores' bytes together; beyond it the least recently opened go
};

/// The files of [tls] (or --tls-cert, --tls-key, --tls-ca): with a certificate, both listeners speak TLS only.
struct TlsFiles {
  std::filesystem::path cert;  ///< PEM: the server's certificate, then any intermediate certificates
  std::filesystem::path key;   ///< PEM: its private key (not encrypted)
  std::filesystem::path ca;    ///< PEM, optional: clients must present a certificate signed by one of these
  bool enabled() const { return !cert.empty(); }
};

struct ServerConfig {
  // [server]
  std::string host = "127.0.0.1";
  int port = 7420;                          ///< 0 picks a free port (printed, and written to --port-file)
  std::filesystem::path datasets = "demo";  ///< directory whose subdirectories are stores (and .vdb files)
  int ioThreads = 2;
  /// Threads that encode sessions' video frames, and their still frames with encodeAside (off the render and I/O
  /// threads).
  int encodeThreads = 2;
  /// Still frames (png, jpeg, zstd_rgba8) are encoded by the session on the encoder threads, so that a render
  /// thread goes on to its next frame meanwhile; false: on the render thread, as each is drawn.
  bool encodeAside = true;
  int renderThreads = 2;                            ///< each with its own GL context
  render::Backend backend = render::Backend::Auto;  ///< "auto" | "egl" | "osmesa" in the file
  std::string logLevel = "info";                    ///< trace | debug | info | warn | error | off
  SchedulerConfig scheduler;  ///< [scheduler]; coalesce is also [server] coalesce
  QuotaConfig quotas;         ///< [quotas]
  // [limits]
  int maxSessions = 64;                    ///< connections beyond this are refused with LimitExceeded
  uint32_t maxMessageBytes = 1u << 20;     ///< body of a client message
  int maxImageSide = 4096;                 ///< per side of a requested frame
  double idleTimeoutS = 300;               ///< no message (and no frame outstanding) for this long closes
  double readTimeoutS = 30;                ///< a message whose header arrived must complete within this
  double writeTimeoutS = 30;               ///< a reply must be taken by the client within this
  uint64_t maxOutputBytes = 256ull << 20;  ///< replies queued for a session that does not read
  /// The most a Render may cost, in millions of samples as FramePlan::estimatedSamples bounds them (an upper
  /// estimate, 5-20x the samples a frame takes): a 4096² frame of a 1024³ volume at the default step fits, 4096² at
  /// step 0.001 does not. A mesh frame counts its fragments, bounded by each drawn tet's projected bounding box, plus
  /// 16 a tet (TetRenderer::estimatedCost: 2-4x the fragments it draws).
  double maxRenderMSamples = 100000;
  // Hostile clients (PROTOCOL.md section 3, "Connections"): sockets that never speak, clients that never read.
  // max_sessions counts connections past Hello only, and read_timeout_s runs from a message's first byte
  // (Session).
  int maxPendingConnections = 16;             ///< connections without Hello yet; one more evicts the oldest
  double helloTimeoutS = 5;                   ///< a connection's Hello must be complete within this of its accept
  int maxConnectionsPerAddress = 32;          ///< connections of one client IP address, pending or not; 0: no limit
  bool loopbackExempt = true;                 ///< loopback clients are not held to maxConnectionsPerAddress
  uint64_t pauseReadingBytes = 1ull << 20;    ///< a session with more replies queued is not read until they drain
  uint64_t maxTotalOutputBytes = 1ull << 30;  ///< replies queued for all sessions; a frame beyond it: LimitExceeded
  // [http] The browser's transport (proto/PROTOCOL.md, "WebSocket transport"): the embedded viewer over HTTP and
  // the protocol over a WebSocket on /ws, on a port of its own.
  bool http = false;                     ///< whether to listen for HTTP (http.port > 0 in the file, or --http)
  int httpPort = 0;                      ///< 0 picks a free port (printed, and written to --http-port-file)
  std::string httpBind;                  ///< listen address; empty: the same as host
  std::vector<std::string> httpOrigins;  ///< origins allowed to open /ws besides the page's own ("http://h:p")
  std::string httpToken;                 ///< when set, /ws must be opened with ?token=<it>
  // [[tokens]] and [access]: who may see which datasets (AccessTokens).
  std::vector<TokenConfig> tokens;
  /// The datasets a session without a token may list and open; absent: every dataset when no [[tokens]] are
  /// configured, none otherwise.
  std::optional<std::vector<std::string>> anonymousDatasets;
  // [upload]
  UploadConfig upload;
  // [[pacs]], [pacs_cache]
  std::vector<PacsConfig> pacs;
  PacsCacheConfig pacsCache;
  // [tls]
  TlsFiles tls;  ///< TLS on both listeners (TCP, and https/wss on the HTTP port) when it names a certificate
  // [audit] The audit trail (AuditLog): one line per session, token, dataset opened and refusal.
  std::filesystem::path auditPath;       ///< empty: none
  uint64_t auditMaxBytes = 10ull << 20;  ///< the file is rotated once it would pass this
  int auditKeep = 5;                     ///< rotated files kept (path.1 ... path.KEEP)
  // [memory]
  int64_t hostCacheMB = 1024;  ///< decoded bricks of all open datasets together
  int64_t gpuBudgetMB = 1024;  ///< atlases of all render threads and datasets (equal shares per thread)
  int64_t videoMB = 4096;      ///< the sessions' video encoders together (VideoMemory)
  /// Without coalescing (a benchmark setting), how many renders one session may have waiting.
  static constexpr size_t kMaxQueuedWithoutCoalescing = 64;
  /// How many renders of one session may wait for a render thread (Capabilities.max_queued_per_session).
  size_t maxQueuedPerSession() const { return scheduler.coalesce ? 1 : kMaxQueuedWithoutCoalescing; }

  /// Reads `path` (TOML) over the defaults. Throws std::runtime_error naming the file, key and problem for a
  /// syntax error, an unknown key, a wrong type, a value out of range or an unknown backend name.
  static ServerConfig load(const std::filesystem::path& path);
  /// Throws std::runtime_error naming the first value out of range.
  void validate() const;
  /// Throws std::runtime_error naming the first token that is not valid ([[tokens]], access.anonymous).
  void validateTokens() const;
  /// The address the HTTP listener binds: httpBind, else host.
  const std::string& httpHost() const { return httpBind.empty() ? host : httpBind; }
  /// The backend named `text` ("auto", "egl" or "osmesa"); throws std::runtime_error naming `what` (the key or
  /// option it came from) and the bad value.
  static render::Backend parseBackend(const std::string& text, const std::string& what);
};

}  // namespace voxbrick::server
