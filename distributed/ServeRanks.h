// `voxbrick serve --mpi`: rank 0 runs the normal server with one render thread whose grid frames go through the
// FrameLeader (a RenderEngineOptions::gridFrames hook, so server/ knows nothing of MPI); every other rank runs
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
#include "render/engine/RenderEngine.h"

namespace voxbrick::distributed {

/// What rank 0 and the workers share: the datasets directory (each rank's own), compositing and the deadline.
struct ServeRankOptions {
  std::filesystem::path datasets;
  RankRendererOptions frames;
  size_t hostCacheBytes = size_t(1) << 30;  ///< a worker's decoded bricks, all its open datasets together
  render::RenderEngineOptions engine;       ///< a worker's engine (backend, GPU budget)
};

/// Rank 0's side: the hook that turns one grid frame into a command for every rank and a composited frame.
class FrameLeader {
 public:
  FrameLeader(MPI_Comm comm, ServeRankOptions options);
  /// The hook for RenderEngineOptions::gridFrames (it keeps this object alive).
  render::GridFrames hook();
  /// The check for ServerConfig::datasetCheck: every rank opens `name` from its datasets directory and they compare
  /// it with rank 0's; throws RenderInputError naming a rank where it is missing or different (RenderError after a
  /// lost rank). Waits for a frame in progress.
  void checkDataset(const std::string& name);
  /// Tells every worker to leave (after the server has stopped and no frame is being drawn); a worker that does not
  /// take it within a second is left behind. Returns whether every rank was told.
  bool quit();

 private:
  std::string ownRecord(const std::string& name) const;
  image::ImageF frame(render::RenderEngine& engine, const std::shared_ptr<const render::Dataset>& dataset,
                      const render::Scene& scene, render::FrameStats* stats, const render::FrameOptions& options);
  MPI_Comm mComm;
  ServeRankOptions mOptions;
  std::mutex mMutex;                 // one frame at a time
  std::optional<std::string> mLost;  // why the ranks are no longer in step
  std::unique_ptr<RankRenderer> mRenderer;
  render::RenderEngine* mEngine = nullptr;
};

/// A worker's loop (ranks > 0): frames until rank 0 says to quit, or until `stopRequested` has been true for
/// `graceSeconds` without rank 0 saying so (SIGTERM reaches every rank; rank 0 should send quit first). Returns
/// whether every rank is still in step, so that MPI_Finalize (which waits for every rank) may be called: false after
/// a lost rank, a failed transfer, or leaving without rank 0's word.
bool runWorker(MPI_Comm comm, const ServeRankOptions& options, const std::atomic<bool>& stopRequested,
               double graceSeconds = 5);

}  // namespace voxbrick::distributed
