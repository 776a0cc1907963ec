// `voxbrick serve --mpi`: rank 0 runs the normal server with one render thread whose frame source is a
// SortLastSource (server/ sees only a render::FrameSource and knows nothing of MPI): frames of a kind that sorts last
// go through the FrameLeader to every member of the group drawing frames, the others are drawn by rank 0's own
// engine. Every other rank runs runWorker, which takes each frame's command from rank 0 (the dataset's name, the
// scene, rank 0's interactive rate, the members), opens the dataset from its own datasets directory (the same files
// on every rank, or the frame is refused naming the rank), draws its part and composites.
//
// A rank lost (a transfer failed, or passed the deadline) is named in that frame's error. Before the next frame rank 0
// regroups: it asks every other rank to answer in a new epoch, and the ranks that answer within the deadline are the
// members from then on; the dataset is split among them, so frames stay equal to one process's. The frames' stats
// name the lost ranks. A rank that answers too late to a regroup is taken back at the next frame.
#pragma once

#include <mpi.h>

#include <atomic>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "distributed/Cluster.h"
#include "distributed/RankRenderer.h"
#include "render/core/Interactive.h"
#include "render/engine/FrameSource.h"
#include "render/engine/RenderEngine.h"

namespace voxbrick::distributed {

/// What rank 0 and the workers share: the datasets directory (each rank's own), compositing and the deadline.
struct ServeRankOptions {
  std::filesystem::path datasets;
  RankRendererOptions frames;
  size_t hostCacheBytes = size_t(1) << 30;  ///< a worker's decoded bricks, all its open datasets together
  render::RenderEngineOptions engine;       ///< a worker's engine (backend, GPU budget)
};

/// Rank 0's side: turns one frame into a command for every member and a composited frame, checks datasets on every
/// member, regroups the ranks after a loss, and tells the workers to leave. Thread-safe: one frame or check at a time.
class FrameLeader {
 public:
  FrameLeader(MPI_Comm comm, ServeRankOptions options);
  ~FrameLeader();
  FrameLeader(const FrameLeader&) = delete;
  FrameLeader& operator=(const FrameLeader&) = delete;

  /// One frame across the members, rank 0's part drawn through `renderer`; an interactive frame's rung is chosen on
  /// every rank by options.rateSamplesPerMs, else by `recentRate` (the group's recent frames'), else the cheapest.
  /// After a lost rank the ranks regroup first (up to the deadline and 2 s more). Throws RenderError naming a rank
  /// lost during this frame.
  /// With `frame8`: as RankRenderer::render's.
  image::ImageF frame(RankRenderer& renderer, double recentRate, const std::shared_ptr<const render::Dataset>& dataset,
                      const render::Scene& scene, render::FrameStats* stats, const render::FrameOptions& options,
                      image::Image8* frame8 = nullptr);
  /// Every member opens `name` from its datasets directory and they compare it with rank 0's; throws
  /// RenderInputError naming a rank where it is missing or different, RenderError naming a rank lost meanwhile.
  /// Waits for a frame in progress.
  void checkDataset(const std::string& name);
  /// Tells every worker to leave (after the server has stopped and no frame is being drawn); a worker that does not
  /// take it within a second is left behind. Returns whether every rank was told and none was ever lost.
  bool quit();

 private:
  struct LateAnswer;
  std::string ownRecord(const std::string& name) const;
  /// A transfer failed: the frame's error, and a regroup before the next frame.
  render::RenderError lose(const PeerError& error, const char* what);
  /// Asks `candidates` to answer in a new epoch; those that answer within the deadline are the members.
  void regroup(const std::vector<int>& candidates);
  /// Regroups first when a rank was lost, or when a rank left out answered a regroup since.
  void regroupIfNeeded();

  MPI_Comm mComm;
  ServeRankOptions mOptions;
  int mWorldSize = 1;
  std::mutex mMutex;                    // one frame at a time
  RankGroup mGroup;                     // the members and their epoch
  nlohmann::json mLost;                 // [{rank, reason}]: ranks not drawing now
  std::optional<std::string> mFailure;  // a rank lost since the last regroup: why
  int mSuspect = -1;                    // the rank that failure named
  std::optional<std::string> mStopped;  // the distributed mode gave up (no epoch left): why
  bool mEverLost = false;
  std::vector<LateAnswer> mLate;  // answers to the last regroup still awaited from ranks left out
};

/// The frame source of rank 0's render thread: its own RenderEngine (options.engine), frames of kinds that sort last
/// (DatasetDriver::sortsLast) drawn across every rank through the leader, the others by the engine alone.
class SortLastSource final : public render::FrameSource {
 public:
  /// Makes the engine (a GL context, current on the calling thread until releaseCurrent).
  SortLastSource(std::shared_ptr<FrameLeader> leader, MPI_Comm comm, const ServeRankOptions& options);
  void makeCurrent() override { mEngine.makeCurrent(); }
  void releaseCurrent() override { mEngine.releaseCurrent(); }
  std::string describe() const override;
  image::ImageF render(const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene,
                       render::FrameStats* stats = nullptr, const render::FrameOptions& options = {}) override;
  /// The 8-bit frame as the compositor made it (no widening to floats and back).
  image::Image8 render8(const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene,
                        render::FrameStats* stats = nullptr, const render::FrameOptions& options = {}) override;
  /// Pages ahead for datasets drawn by rank 0 alone; a sort-last frame's parts lie on every rank, so none there.
  void prefetch(const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene) override;
  void checkDataset(const std::string& name) override { mLeader->checkDataset(name); }
  size_t gpuBytes() const override { return mEngine.gpuBytes(); }
  size_t peakGpuBytes() const override { return mEngine.peakGpuBytes(); }
  uint64_t renderersReleased() const override { return mEngine.renderersReleased(); }

 private:
  /// A sort-last frame through the leader; its whole-frame samples and time go to the kind's rate.
  image::ImageF distributed(const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene,
                            render::FrameStats* stats, const render::FrameOptions& options, image::Image8* frame8);

  std::shared_ptr<FrameLeader> mLeader;
  render::RenderEngine mEngine;
  RankRenderer mRenderer;
  int mRanks = 1;
  /// Per dataset kind, what the group's frames took as a whole (RankRenderer's stats: every member's samples, rank
  /// 0's time to the composited frame): the rate an interactive frame of a session with none measured yet is chosen
  /// by. (The engine's own rate is rank 0's part alone, a whole frame's cost about the ranks' count too high.)
  std::map<std::string, render::RateGauge, std::less<>> mRates;
};

/// A worker's loop (ranks > 0): frames until rank 0 says to quit, or until `stopRequested` has been true for
/// `graceSeconds` without rank 0 saying so (SIGTERM reaches every rank; rank 0 should send quit first). A frame that
/// fails on a transfer is left, and the worker waits for rank 0's next command (a regroup, which it answers). Returns
/// whether every rank is still in step, so that MPI_Finalize (which waits for every rank) may be called: false after
/// a lost rank, or leaving without rank 0's word.
bool runWorker(MPI_Comm comm, const ServeRankOptions& options, const std::atomic<bool>& stopRequested,
               double graceSeconds = 5);

}  // namespace voxbrick::distributed
