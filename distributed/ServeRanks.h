// `voxbrick serve --mpi`: rank 0 runs the normal server with one render thread whose frame source is a
// SortLastSource (server/ sees only a render::FrameSource and knows nothing of MPI): frames of a kind that sorts last
// go through the FrameLeader to every rank, the others are drawn by rank 0's own engine. Every other rank runs
// runWorker, which takes each frame's command from rank 0 (the dataset's name, the scene, rank 0's interactive rate),
// opens the dataset from its own datasets directory (the same files on every rank, or the frame is refused naming
// the rank), draws its part and composites. A rank that fails or passes the deadline is named in the frame's error,
// and the distributed mode then refuses every later frame with that reason (the server goes on answering).
#pragma once

#include <mpi.h>

#include <atomic>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "distributed/RankRenderer.h"
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

/// Rank 0's side: turns one frame into a command for every rank and a composited frame, checks datasets on every
/// rank, and tells the workers to leave. Thread-safe: one frame or check at a time.
class FrameLeader {
 public:
  FrameLeader(MPI_Comm comm, ServeRankOptions options);
  /// One frame across the ranks, rank 0's part drawn through `renderer`; an interactive frame's rung is chosen on
  /// every rank by options.rateSamplesPerMs, else by `recentRate` (rank 0's engine's), else the cheapest. Throws
  /// RenderError naming a lost rank (and refuses every later frame with that reason).
  image::ImageF frame(RankRenderer& renderer, double recentRate, const std::shared_ptr<const render::Dataset>& dataset,
                      const render::Scene& scene, render::FrameStats* stats, const render::FrameOptions& options);
  /// Every rank opens `name` from its datasets directory and they compare it with rank 0's; throws
  /// RenderInputError naming a rank where it is missing or different (RenderError after a lost rank). Waits for a
  /// frame in progress.
  void checkDataset(const std::string& name);
  /// Tells every worker to leave (after the server has stopped and no frame is being drawn); a worker that does not
  /// take it within a second is left behind. Returns whether every rank was told.
  bool quit();

 private:
  std::string ownRecord(const std::string& name) const;
  MPI_Comm mComm;
  ServeRankOptions mOptions;
  std::mutex mMutex;                 // one frame at a time
  std::optional<std::string> mLost;  // why the ranks are no longer in step
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
  /// Pages ahead for datasets drawn by rank 0 alone; a sort-last frame's parts lie on every rank, so none there.
  void prefetch(const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene) override;
  void checkDataset(const std::string& name) override { mLeader->checkDataset(name); }
  size_t gpuBytes() const override { return mEngine.gpuBytes(); }
  size_t peakGpuBytes() const override { return mEngine.peakGpuBytes(); }
  uint64_t renderersReleased() const override { return mEngine.renderersReleased(); }

 private:
  std::shared_ptr<FrameLeader> mLeader;
  render::RenderEngine mEngine;
  RankRenderer mRenderer;
  int mRanks = 1;
};

/// A worker's loop (ranks > 0): frames until rank 0 says to quit, or until `stopRequested` has been true for
/// `graceSeconds` without rank 0 saying so (SIGTERM reaches every rank; rank 0 should send quit first). Returns
/// whether every rank is still in step, so that MPI_Finalize (which waits for every rank) may be called: false after
/// a lost rank, a failed transfer, or leaving without rank 0's word.
bool runWorker(MPI_Comm comm, const ServeRankOptions& options, const std::atomic<bool>& stopRequested,
               double graceSeconds = 5);

}  // namespace voxbrick::distributed
