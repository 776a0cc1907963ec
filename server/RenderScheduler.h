// The render queue and the render threads. Sessions with a job waiting are served in turn; when coalescing, each
// holds at most one waiting job and a newer one replaces it (latest wins). Each thread owns a RenderEngine.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "render/engine/RenderEngine.h"
#include "server/RenderJob.h"

namespace voxbrick::server {

class RenderScheduler {
 public:
  /// Where the replies to one session's jobs go.
  class Sink {
   public:
    virtual ~Sink() = default;
    /// False once the session has ended: its waiting jobs are then dropped unrendered. Called on render threads.
    virtual bool wantsReplies() const = 0;
    /// Takes the reply to `job` on a render thread; must not block (a session posts it to its own strand).
    virtual void rendered(RenderJob job, proto::Message reply) = 0;
  };

  /// Takes the engines (made, and released from the calling thread, by the caller: a machine without GL fails
  /// there, before any thread exists). `coalesce` false keeps up to ServerConfig::kMaxQueuedWithoutCoalescing jobs
  /// per session instead of one.
  RenderScheduler(std::vector<std::unique_ptr<render::RenderEngine>> engines, bool coalesce);
  /// stop().
  ~RenderScheduler();
  RenderScheduler(const RenderScheduler&) = delete;
  RenderScheduler& operator=(const RenderScheduler&) = delete;

  /// Starts one render thread per engine; each engine moves to its thread, which makes it current there and
  /// destroys it there. Once.
  void start();
  /// Queues `job` for `sink`'s session; thread-safe. Only Submission::Result::Queued means a reply will come.
  Submission submit(const std::shared_ptr<Sink>& sink, RenderJob job);
  /// Queues the exact frame of `job`, a progressive request just answered with a provisional frame, unless the
  /// session has a newer job waiting (its camera moved on) or the server is stopping; a newer submit replaces it.
  /// Thread-safe.
  void refine(const std::shared_ptr<Sink>& sink, RenderJob job);
  /// The atlases of all render threads' engines, as each thread last saw them after a job.
  struct GpuGauges {
    size_t bytes = 0, peakBytes = 0;  ///< peakBytes: the sum of each thread's peak
    uint64_t renderersReleased = 0;
  };
  GpuGauges gpu() const;
  /// How many sessions have a job waiting.
  size_t queuedSessions() const;
  /// Frames given up part way: their session had gone, or a refinement was overtaken by a newer Render.
  uint64_t cancelled() const { return mCancelled.load(); }
  /// Drops every waiting job, lets each thread finish the frame it is drawing (its reply is still delivered) and
  /// joins the threads. Idempotent; call it from any thread but a render thread.
  void stop();

 private:
  void renderLoop(std::unique_ptr<render::RenderEngine> engine, int index);
  /// Appends `job` to the session's waiting jobs, giving the session a turn if it had none. mMutex held.
  void enqueueLocked(const std::shared_ptr<Sink>& sink, RenderJob job);
  /// Blocks for the next job; false once stopping.
  bool next(std::shared_ptr<Sink>& sink, RenderJob& job);
  /// Whether `sink`'s session has a job waiting.
  bool waiting(const Sink& sink) const;

  const bool mCoalesce;
  mutable std::mutex mMutex;
  std::condition_variable mReady;
  bool mStopping = false;
  /// Sessions with a job waiting, each once, in the order they are served.
  std::deque<std::shared_ptr<Sink>> mTurns;
  /// Their waiting jobs, oldest first; a session has an entry exactly while it is in mTurns.
  std::map<const Sink*, std::deque<RenderJob>> mWaiting;
  std::vector<std::unique_ptr<render::RenderEngine>> mEngines;  ///< until start() hands them to their threads
  struct EngineGauge {
    std::atomic<size_t> bytes{0}, peakBytes{0};
    std::atomic<uint64_t> released{0};
  };
  std::unique_ptr<EngineGauge[]> mGauges;  ///< one per engine, written by its thread
  size_t mGaugeCount = 0;
  std::atomic<uint64_t> mCancelled{0};
  std::mutex mJoinMutex;
  std::vector<std::thread> mThreads;
};

}  // namespace voxbrick::server
