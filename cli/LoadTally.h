// What `voxbrick load`'s clients count as they run (in all, and per well-behaved client), and the report made of it:
// the JSON of --json and the summary line.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/LoadFaults.h"

namespace voxbrick::cli {

/// One well-behaved client's figures (a plain or dragging client; faulty ones have none).
struct ClientFigures {
  int64_t frames = 0;  ///< frames received (a dragging client: first replies to its Renders)
  /// When its first frame came, in seconds from the run's start (none yet): a client the server let in late (Busy
  /// at first) is judged by its frames a second from then.
  std::optional<double> firstFrameS;
  int64_t busy = 0;    ///< requests answered Busy (or LimitExceeded with a retry hint), waited out
  /// --drag-cycle: its drags that got a frame, and how long after the drag's first camera the first came (ms, each);
  /// its drags that ended without one (refused Busy throughout). A drag the run's end cut short is in neither.
  int64_t dragsTaken = 0, dragsRefused = 0;
  std::vector<double> dragWaitsMs;
  /// --drag-cycle: from each drag's release (its still Render) to that Render's frame, ms.
  std::vector<double> releaseWaitsMs;
  int64_t errors = 0;
  std::vector<double> latencies;  ///< ms, one per frame
};

/// What the load's clients add to as they run; every field is written under `mutex`.
struct Tally {
  explicit Tally(int clientCount) : clients(size_t(clientCount)) {}

  std::mutex mutex;
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();  ///< the run's start
  std::vector<double> latencies;
  std::vector<double> renderMs;      ///< the renderer's own frame time (frame statistics), well-behaved clients
  std::vector<double> renderMsWarm;  ///< the same without each client's first frame (which pages its bricks in)
  std::vector<double> budgetMs;      ///< interactive frames: the time budget each was drawn to (its statistics)
  std::vector<double> decodeMs;      ///< dragging clients: each video frame's decoding time
  std::vector<double> encodeMs;      ///< dragging clients: each frame's encoding time on the server (its statistics)
  /// Dragging clients' interactive frames: each drawing's scale (`interactive.scale`), and the scale each was sent at
  /// (a video frame's stream scale, `video.scale`; another frame's own width), as fractions of the scene's sides.
  std::vector<double> drawnScale, sentScale;
  /// Interactive frames chosen by a known rate: the time their drawing was predicted to take, and took (ms).
  std::vector<double> predictedMs, actualMs;
  int64_t videoFrames = 0, keyFrames = 0;  ///< video frames received (first replies and not), key frames among them
  int64_t fullChromaFrames = 0;            ///< video frames in 4:4:4 (`video.chroma`; --vp9-444) among them
  int64_t frames = 0, errors = 0, superseded = 0, payloadBytes = 0;
  int64_t provisional = 0;       ///< dragging clients: first replies that were provisional frames
  int64_t exactFollowUps = 0;    ///< dragging clients: exact frames of requests a provisional frame already answered
  int64_t busy = 0;              ///< requests (or sessions) answered Busy, each waited out before the next request
  int64_t batchRefused = 0;      ///< clients whose server did not know the scene key batch, and went on without it
  uint16_t protocolVersion = 0;  ///< the lowest version a well-behaved client's session spoke (0: none began)
  std::vector<ClientFigures> clients;  ///< per well-behaved client, by index
  std::vector<std::string> errorSamples;
  std::map<std::string, int64_t> faultsDone, faultsUnexpected;

  /// Counts an error (of well-behaved client `client`, or -1 for none of them) and keeps its text among the samples.
  /// Takes the lock.
  void error(const std::string& what, int client = -1);
  /// Counts a Busy reply of client `client`. Call with the lock held.
  void countBusy(int client);
  /// Counts a frame (a first reply) of client `client`, with its latency. Call with the lock held.
  void countFrame(int client, double latencyMs);
};

/// The value below which a share `p` in [0, 1] of `v` lies (the largest for p = 1); 0 when `v` is empty.
double percentile(std::vector<double> v, double p);

/// Jain's fairness index of `x` (e.g. each client's frames a second): (Σx)² / (n Σx²), in [1/n, 1], 1 when all are
/// equal; none when `x` is empty or all zero.
std::optional<double> jainIndex(const std::vector<double>& x);

/// Per fault, how often it ran and how many replies were not as documented; `unexpected` gets the total of those.
nlohmann::json faultCounts(const Tally& tally, int64_t& unexpected);

/// The run as JSON (--json): totals, latency percentiles, the server's statistics after the run (`server`) and as it
/// began (`server_before`), and per well-behaved client its frames, frames a second, latency p50/p99 and Busy
/// replies, with Jain's index over their frames a second. `scene`: the first scene the first client sends.
nlohmann::json loadReport(const LoadArgs& a, const Tally& tally, double seconds, int width, int height,
                          const nlohmann::json& faults, const nlohmann::json& server,
                          const nlohmann::json& serverBefore, const nlohmann::json& scene);

/// The one-line summary on standard output, then the error samples.
void printSummary(const LoadArgs& a, const Tally& tally, double seconds, int64_t unexpected,
                  const nlohmann::json& server);

}  // namespace voxbrick::cli
