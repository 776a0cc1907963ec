// The render queue and the render threads. Sessions with a job waiting are served in turn; when coalescing, each
// holds at most one waiting job and a newer one replaces it (latest wins). Each thread draws with a FrameSource of
// its own: the local engine, the distributed mode's, or the null source of the tests (render/engine/FrameSource.h).
#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "render/core/Interactive.h"
#include "render/engine/FrameSource.h"
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

  /// Takes the frame sources, one per render thread (made, and released from the calling thread, by the caller: a
  /// machine without GL fails there, before any thread exists). `coalesce` false keeps up to
  /// ServerConfig::kMaxQueuedWithoutCoalescing jobs per session instead of one.
  RenderScheduler(std::vector<std::unique_ptr<render::FrameSource>> sources, bool coalesce);
  /// stop(), then the sources are destroyed (each made current on this thread first, as RenderEngine does).
  ~RenderScheduler();
  RenderScheduler(const RenderScheduler&) = delete;
  RenderScheduler& operator=(const RenderScheduler&) = delete;

  /// Starts one render thread per source, which makes it current there and releases it when the thread ends. Once.
  void start();
  /// FrameSource::checkDataset of every source: whether the dataset `name` may be served (the distributed mode:
  /// every rank opens it and they agree). Throws what a source throws. Thread-safe.
  void checkDataset(const std::string& name);
  /// Queues `job` for `sink`'s session; thread-safe. Only Submission::Result::Queued means a reply will come.
  Submission submit(const std::shared_ptr<Sink>& sink, RenderJob job);
  /// Queues the exact frame of `job`, a request just answered with a provisional frame, unless the session has a
  /// newer job waiting, or received one after `job` (its camera moved on), or the server is stopping; a newer submit
  /// replaces it (or, without coalescing, drops it). The exact frame of an interactive request waits restMs(sink)
  /// first, so that it does not start while the camera still moves; a progressive one is queued at once. Thread-safe.
  void refine(const std::shared_ptr<Sink>& sink, RenderJob job);
  /// How long the exact frame of an interactive request of `sink`'s session waits for the camera to rest: one and a
  /// half times the interval between the session's last two Renders (a camera still moving sends its next one within
  /// it), at most kMaxRestMs (so that the exact frame follows within about 200 ms of the last frame when the
  /// camera stops), and kMaxRestMs before the session has sent two Renders.
  double restMs(const Sink& sink) const;
  static constexpr double kMaxRestMs = 150;
  /// The atlases of all render threads' sources, as each thread last saw them after a job.
  struct GpuGauges {
    size_t bytes = 0, peakBytes = 0;  ///< peakBytes: the sum of each thread's peak
    uint64_t renderersReleased = 0;
  };
  GpuGauges gpu() const;
  /// How many sessions have a job waiting.
  size_t queuedSessions() const;
  /// Jobs waiting, by the class of each (frameClassOf), indexed by FrameClass.
  std::array<size_t, kFrameClasses> queuedByClass() const;
  /// Milliseconds each render thread has spent drawing and encoding since it started, in thread order.
  std::vector<double> deviceBusyMs() const;
  /// Frames given up part way: their session had gone, or a refinement was overtaken by a newer Render.
  uint64_t cancelled() const { return mCancelled.load(); }
  /// Drops every waiting job, lets each thread finish the frame it is drawing (its reply is still delivered) and
  /// joins the threads. Idempotent; call it from any thread but a render thread.
  void stop();

 private:
  void renderLoop(render::FrameSource& source, int index);
  /// Appends `job` to the session's waiting jobs, giving the session a turn if it had none. mMutex held.
  void enqueueLocked(const std::shared_ptr<Sink>& sink, RenderJob job);
  /// Blocks for the next job; false once stopping.
  bool next(std::shared_ptr<Sink>& sink, RenderJob& job);
  /// Whether `sink`'s session has a job waiting.
  bool waiting(const Sink& sink) const;
  /// The first session in turn whose first job is due (notBefore passed), taken out of mTurns; null if none, with
  /// `earliest` the soonest time one becomes due (max if no job waits for a time). mMutex held.
  std::shared_ptr<Sink> takeDueLocked(std::chrono::steady_clock::time_point& earliest);

  /// What the scheduler knows of a session beyond its waiting jobs: its rates and the pace of its Renders.
  struct SessionPace {
    std::weak_ptr<Sink> owner;
    std::map<std::string, render::RateGauge, std::less<>> rates;  // by the dataset's kind
    std::chrono::steady_clock::time_point lastReceived{};
    double intervalMs = 0;  // between its last two Renders; 0 before the second
  };
  /// The session's entry, made if need be (sessions gone are dropped on the way). mMutex held.
  SessionPace& paceLocked(const std::shared_ptr<Sink>& sink);

  const bool mCoalesce;
  mutable std::mutex mMutex;
  std::condition_variable mReady;
  bool mStopping = false;
  /// Sessions with a job waiting, each once, in the order they are served.
  std::deque<std::shared_ptr<Sink>> mTurns;
  /// Their waiting jobs, oldest first; a session has an entry exactly while it is in mTurns.
  std::map<const Sink*, std::deque<RenderJob>> mWaiting;
  std::map<const Sink*, SessionPace> mPaces;
  /// One per render thread, for the scheduler's whole life (a thread releases its own when it ends).
  std::vector<std::unique_ptr<render::FrameSource>> mSources;
  struct EngineGauge {
    std::atomic<size_t> bytes{0}, peakBytes{0};
    std::atomic<uint64_t> released{0};
    std::atomic<double> busyMs{0};  ///< drawing and encoding, since the thread started
  };
  std::unique_ptr<EngineGauge[]> mGauges;  ///< one per source, written by its thread
  size_t mGaugeCount = 0;
  std::atomic<uint64_t> mCancelled{0};
  std::mutex mJoinMutex;
  std::vector<std::thread> mThreads;
};

}  // namespace voxbrick::server
