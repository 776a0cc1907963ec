// The render queue and the render threads. Sessions with a job waiting are served by fair queueing on measured
// render time, in classes (FrameClass: interactive, then still, then batch, by weight); when coalescing, each session
// holds at most one waiting job and a newer one replaces it (latest wins). Sessions asking the identical frame at
// once get one render. Each thread draws with a FrameSource of its own: the local engine, the distributed mode's, or
// the null source of the tests (render/engine/FrameSource.h). docs/design/server.md, "Fair under a crowd".
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "render/core/Interactive.h"
#include "render/engine/FrameSource.h"
#include "server/FrameClass.h"
#include "server/RenderJob.h"
#include "server/ServerConfig.h"

namespace voxbrick::server {

class RenderScheduler {
 public:
  using Clock = std::chrono::steady_clock;

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
  /// machine without GL fails there, before any thread exists). `config.coalesce` false keeps up to
  /// ServerConfig::kMaxQueuedWithoutCoalescing jobs per session instead of one.
  RenderScheduler(std::vector<std::unique_ptr<render::FrameSource>> sources, const SchedulerConfig& config);
  /// The default configuration but `coalesce`.
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
  /// Queues `job` for `sink`'s session; thread-safe. Only Submission::Result::Queued means a reply will come. A
  /// batch job expected to wait more than batch_max_wait_ms is refused (Result::Busy, with the wait as the hint).
  Submission submit(const std::shared_ptr<Sink>& sink, RenderJob job);
  /// Queues the exact frame of `job`, a request just answered with a provisional frame, unless the session has a
  /// newer job waiting, or received one after `job` (its camera moved on), or the server is stopping; a newer submit
  /// replaces it (or, without coalescing, drops it). The exact frame of an interactive request waits restMs(sink)
  /// first, so that it does not start while the camera still moves; a progressive one is queued at once. Thread-safe.
  void refine(const std::shared_ptr<Sink>& sink, RenderJob job);
  /// How long the exact frame of an interactive request of `sink`'s session waits for the camera to rest: one and a
  /// half times the longest of the intervals between the session's last kRestIntervals + 1 Renders (a camera still
  /// moving sends its next one within it, a client whose moves come unevenly included), at most kMaxRestMs (so that
  /// the exact frame follows within about 200 ms of the last frame when the camera stops), and kMaxRestMs before the
  /// session has sent two Renders. A rest read too soon costs a whole exact frame on the link, which on a slow link
  /// holds the moving frames behind it (a 1024² png takes 650 ms at 10 Mbit/s); a jittery client's shortest interval
  /// would read one every few moves.
  double restMs(const Sink& sink) const;
  /// The median of the same intervals (a drag's pace: Connection's video bitrate keeps it); none before the session
  /// has sent two Renders.
  std::optional<double> renderIntervalMs(const Sink& sink) const;
  static constexpr double kMaxRestMs = 150;
  static constexpr size_t kRestIntervals = 4;
  /// How long a session counts as dragging after its last interactive Render.
  static constexpr std::chrono::milliseconds kInteractiveWindow{1000};

  /// Why a session may not start dragging now, and when to ask again.
  struct Refusal {
    std::string why;
    uint32_t retryAfterMs = 0;
  };
  /// Whether a new session may be taken now: none when it may. Refused while as many sessions drag as the capacity
  /// (max_interactive_sessions, or measured: the render threads' time over min_interactive_fps frames of the
  /// measured interactive frame cost), or before it is measured, as cold_interactive_sessions_per_thread times the
  /// threads. submit() holds a session's first moving camera (none within kInteractiveWindow) to the same bound, and
  /// in line: a session refused takes a place, and room that opens goes to the places in turn (a first move is taken
  /// only while the sessions dragging and those waiting ahead of it leave room). Thread-safe.
  std::optional<Refusal> refuseNewSession() const;
  /// The hint of a refused first move: kLineStepMs for the first kPlacesAStep places in line, a step more for each
  /// kPlacesAStep behind, at most kLineMaxHintMs; a new session's at Hello (busy_at_hello: it has no place),
  /// kOverCapacityHintMs. Room is held only for those ahead due back within kLineStepMs: one told to come back later
  /// does not keep it idle meanwhile. A place is kept while the session asks again within its hint and kLineGrace; a
  /// still Render gives it up (the drag was released).
  static constexpr uint32_t kLineStepMs = 250, kPlacesAStep = 8, kLineMaxHintMs = 1000, kOverCapacityHintMs = 2000;
  static constexpr std::chrono::milliseconds kLineGrace{1000};

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
  /// Milliseconds each render thread has spent drawing and encoding since it started, in thread order, the frame in
  /// progress included.
  std::vector<double> deviceBusyMs() const { return threadMs(EngineGauge::Busy); }
  /// Milliseconds each render thread has spent asking the scheduler for its next job (waiting for work, or for the
  /// scheduler's lock), in thread order, the wait in progress included. Its time beyond this and deviceBusyMs went to
  /// handing frames on and paging ahead.
  std::vector<double> deviceWaitMs() const { return threadMs(EngineGauge::Waiting); }
  /// Sessions that sent an interactive Render within kInteractiveWindow.
  size_t interactiveSessions() const;
  /// How many sessions may drag before a new one is answered Busy: max_interactive_sessions, else measured (the
  /// render threads' time over min_interactive_fps times the render time a moving frame costs, the interactive
  /// class's other work included); 0 while not yet measured (no limit).
  size_t interactiveCapacity() const;
  /// Frames given up part way: their session had gone, or a refinement was overtaken by a newer Render.
  uint64_t cancelled() const { return mCancelled.load(); }
  /// Replies delivered from another session's render of the identical frame.
  uint64_t sharedFrames() const { return mShared.load(); }
  /// Batch Renders refused Busy.
  uint64_t busyRenders() const { return mBusyRenders.load(); }
  /// Moving cameras refused Busy: sessions' first beyond refuseNewSession's bound, and those of drags whose turn ended.
  uint64_t busyDrags() const { return mBusyDrags.load(); }
  /// Sessions in line to drag: refused a first move, their place still held.
  size_t waitingToDrag() const;
  /// Drags whose turn ended (interactive_turn_s): a moving camera answered Busy while others waited in line.
  uint64_t turnsEnded() const { return mTurnsEnded.load(); }
  /// Drops every waiting job, lets each thread finish the frame it is drawing (its reply is still delivered) and
  /// joins the threads. Idempotent; call it from any thread but a render thread.
  void stop();

 private:
  /// A job with the sessions it answers: its own, and those that asked the identical frame meanwhile.
  struct Recipient {
    std::shared_ptr<Sink> sink;
    RenderJob job;
  };
  struct Taken {
    std::shared_ptr<Sink> sink;
    RenderJob job;
    FrameClass frameClass = FrameClass::Still;
    double charged = 0;  ///< the predicted ms charged at dispatch, corrected once the frame is drawn
    std::string shareKey;
  };

  void renderLoop(render::FrameSource& source, int index);
  /// Appends `job` to the session's waiting jobs, catching up its fair-queueing tags if it had none. mMutex held.
  void enqueueLocked(const std::shared_ptr<Sink>& sink, RenderJob job);
  /// Blocks for the next job; false once stopping.
  bool next(Taken& taken);
  /// Whether `sink`'s session has a job waiting.
  bool waiting(const Sink& sink) const;
  /// The session to serve next by class weight, then by fair-queueing tag within the class, among those whose first
  /// job is due (notBefore passed) and whose class may take a thread now; null if none, with `earliest` the soonest
  /// time one becomes due (max if no job waits for a time). mMutex held.
  std::shared_ptr<Sink> pickLocked(Clock::time_point now, Clock::time_point& earliest);
  /// Charges `ms` of render time to `sink`'s session and `cls` (negative: a correction). mMutex held.
  void chargeLocked(const Sink* sink, FrameClass cls, double ms);
  /// The predicted render time of a job of `cls`: the class's recent mean, 50 ms before any. mMutex held.
  double predictedMsLocked(FrameClass cls) const;
  /// The time budget and JPEG quality the crowd leaves an interactive job. mMutex held.
  void fitToLoadLocked(RenderJob& job, Clock::time_point now) const;
  size_t interactiveSessionsLocked(Clock::time_point now) const;
  /// The dragging sessions the render threads can keep at min_interactive_fps: max_interactive_sessions, else
  /// measured; 0 before any interactive frame was measured (no limit yet). mMutex held.
  size_t interactiveCapacityLocked() const;
  /// Whether one more session may drag now: refused while the sessions dragging and `ahead` (those in line before
  /// it: none for a new session at Hello, which has no place) fill the capacity, or the cold bound. `place`: the
  /// session's place in line from 0 (its hint), none at Hello. mMutex held.
  std::optional<Refusal> refuseDraggingLocked(Clock::time_point now, size_t ahead, std::optional<size_t> place) const;
  /// The sessions in line to drag at `now` before place `before` (0: all of them): those due back within kLineStepMs
  /// (room is held for them), and all. mMutex held.
  struct LineAhead {
    size_t due = 0, all = 0;
  };
  LineAhead lineAheadLocked(Clock::time_point now, uint64_t before = 0) const;
  /// Delivers `reply` to the job's own session and to every session that rode along (followers).
  void deliver(const Taken& taken, RenderReply& reply, std::vector<Recipient>& followers);

  /// What the scheduler knows of a session: its waiting jobs, rates, the pace of its Renders, its fair share.
  struct SessionState {
    std::weak_ptr<Sink> owner;
    std::deque<RenderJob> waiting;  ///< oldest first
    std::map<std::string, render::RateGauge, std::less<>> rates;  // by the dataset's kind
    Clock::time_point lastReceived{};
    std::deque<double> intervalsMs;  ///< between its last kRestIntervals + 1 Renders, oldest first
    Clock::time_point lastInteractive{};
    /// When its drag under way began (its first moving camera taken).
    Clock::time_point dragSince{};
    /// Its next still Render before this ends a drag that was answered Busy (admission).
    Clock::time_point refusedDragEnds{};
    /// Its place in line to drag (mLineOrder when it took it; 0: none), held until kLineGrace after `lineDue`, when
    /// its last hint ends (it is due back).
    uint64_t linePlace = 0;
    Clock::time_point lineDue{};
    bool inLineAt(Clock::time_point at) const { return linePlace != 0 && at <= lineDue + kLineGrace; }
    /// Whether it sent an interactive Render within kInteractiveWindow before `at` (it counts as dragging then).
    bool draggingAt(Clock::time_point at) const {
      return lastInteractive != Clock::time_point{} && at - lastInteractive <= kInteractiveWindow;
    }
    /// Fair-queueing tags, per class: the render time charged to the session, over its weight (virtual ms).
    std::array<double, kFrameClasses> tag{};
    uint64_t backloggedSince = 0;  ///< the order it last got a job waiting in: ties go to the longest waiting
  };
  /// The session's entry, made if need be (sessions gone are dropped on the way). mMutex held.
  SessionState& stateLocked(const std::shared_ptr<Sink>& sink);
  /// Takes the first of the waiting jobs of `key`'s session (`state`), uncounting it; the session leaves the backlog
  /// when none is left. mMutex held.
  RenderJob popWaitingLocked(const Sink* key, SessionState& state);
  /// Refuses `state`'s moving camera Busy with `refusal` and puts the session in line (a place if it has none, held
  /// for the hint and kLineGrace); a still Render within kOverCapacityHintMs (or the hint, if longer) and a second more
  /// is then this drag's last. mMutex held.
  Submission refuseDragLocked(SessionState& state, const RenderJob& job, Clock::time_point now, Refusal refusal);

  const SchedulerConfig mConfig;
  /// The render threads' time between classes (weights, tags, threads kept for dragging sessions).
  ClassShares mShares;
  mutable std::mutex mMutex;
  std::condition_variable mReady;
  bool mStopping = false;
  std::map<const Sink*, SessionState> mSessions;
  /// Sessions with a job waiting, each once (the owners are kept alive while their jobs wait).
  std::map<const Sink*, std::shared_ptr<Sink>> mBacklog;
  uint64_t mBacklogOrder = 0;
  uint64_t mLineOrder = 0;  ///< the last place in line to drag given out
  /// The latest any place in line is held until (lineDue + kLineGrace of the last refused): after it nobody is in
  /// line, and lineAheadLocked need not look (with turns, every moving camera of a drag past its turn asks it).
  Clock::time_point mLineHeldUntil{};
  /// Per class: the tag of the last session served in it (where a session that had nothing waiting starts again), jobs
  /// waiting and frames being drawn.
  std::array<double, kFrameClasses> mClassClock{};
  std::array<size_t, kFrameClasses> mWaitingByClass{}, mRunningByClass{};
  std::array<double, kFrameClasses> mClassMs{};  ///< recent mean ms per frame
  std::array<uint64_t, kFrameClasses> mClassFrames{};
  /// The interactive class's jobs that ended within kCapacityWindow (moving frames, the exact frames ending drags,
  /// and what was given up part way): when each ended, the ms it was charged, whether it was a moving frame drawn to
  /// the end; and their sums. Their ms over their moving frames is what a moving frame costs the render threads in
  /// all, behind the measured capacity.
  struct InteractiveJobEnd {
    Clock::time_point at;
    double ms = 0;
    bool moving = false;
  };
  static constexpr std::chrono::seconds kCapacityWindow{4};
  std::deque<InteractiveJobEnd> mInteractiveEnds;
  double mInteractiveEndsMs = 0;
  size_t mInteractiveEndsMoving = 0;
  /// Frames being drawn, by their share key, with the sessions that asked the same frame since it started.
  std::map<std::string, std::vector<Recipient>> mInFlight;
  /// One per render thread, for the scheduler's whole life (a thread releases its own when it ends).
  std::vector<std::unique_ptr<render::FrameSource>> mSources;
  struct EngineGauge {
    std::atomic<size_t> bytes{0}, peakBytes{0};
    std::atomic<uint64_t> released{0};
    /// What the thread is doing: drawing and encoding (Busy), asking for its next job (Waiting), or anything else
    /// (handing frames on, paging ahead, starting).
    enum State { Other, Busy, Waiting, kStates };
    /// The thread enters `to` at `now`.
    void enter(State to, std::chrono::steady_clock::time_point now);
    /// Milliseconds spent in `state` until `now`, the interval in progress included (so that a long wait counts as
    /// it goes, not all at its end; the figure only grows).
    double ms(State state, std::chrono::steady_clock::time_point now) const;

   private:
    mutable std::mutex mTiming;
    State mState = Other;
    std::chrono::steady_clock::time_point mSince = std::chrono::steady_clock::now();
    std::array<double, kStates> mMs{};
  };
  /// Each thread's milliseconds in `state` until now (EngineGauge::ms).
  std::vector<double> threadMs(EngineGauge::State state) const;
  std::unique_ptr<EngineGauge[]> mGauges;  ///< one per source, written by its thread
  size_t mGaugeCount = 0;
  std::atomic<uint64_t> mCancelled{0}, mShared{0}, mBusyRenders{0}, mBusyDrags{0}, mTurnsEnded{0};
  std::mutex mJoinMutex;
  std::vector<std::thread> mThreads;
};

/// The key under which two jobs ask the identical frame: the same dataset, scene, encodings, limits and kind of
/// drawing (exact or not). Empty for a job that is never shared (a progressive first frame, whose stand-ins
/// depend on what the thread's atlas holds).
std::string shareKeyOf(const RenderJob& job);

}  // namespace voxbrick::server
