// The latest-wins queue and the render threads.
#include "server/RenderScheduler.h"

#include <stdexcept>
#include <string>
#include <utility>

#include <spdlog/spdlog.h>

#include "server/ErrorReply.h"
#include "server/ServerConfig.h"

namespace voxbrick::server {

RenderScheduler::RenderScheduler(std::vector<std::unique_ptr<render::RenderEngine>> engines, bool coalesce)
    : mCoalesce(coalesce), mEngines(std::move(engines)) {
  if (mEngines.empty()) throw std::invalid_argument("RenderScheduler: no render engine");
  mGaugeCount = mEngines.size();
  mGauges = std::make_unique<EngineGauge[]>(mGaugeCount);
  spdlog::info("render threads: {} x {}", mEngines.size(), mEngines.front()->describe());
}

void RenderScheduler::start() {
  try {
    std::lock_guard joinLock(mJoinMutex);
    for (size_t i = 0; i < mEngines.size(); ++i)
      mThreads.emplace_back(&RenderScheduler::renderLoop, this, std::move(mEngines[i]), int(i));
    mEngines.clear();
  } catch (...) {
    stop();  // the threads already started must not outlive a failed start
    throw;
  }
}

RenderScheduler::~RenderScheduler() { stop(); }

Submission RenderScheduler::submit(const std::shared_ptr<Sink>& sink, RenderJob job) {
  Submission out;
  {
    std::lock_guard lock(mMutex);
    if (mStopping) {
      out.result = Submission::Result::Stopped;
      return out;
    }
    std::deque<RenderJob>& waiting = mWaiting[sink.get()];
    if (mCoalesce && !waiting.empty()) {
      // The one waiting job is replaced in place: the session keeps its turn.
      out.replaced = std::exchange(waiting.front(), std::move(job));
    } else if (waiting.size() >= ServerConfig::kMaxQueuedWithoutCoalescing) {
      out.result = Submission::Result::Full;
      return out;
    } else {
      enqueueLocked(sink, std::move(job));
    }
  }
  mReady.notify_one();
  return out;
}

void RenderScheduler::enqueueLocked(const std::shared_ptr<Sink>& sink, RenderJob job) {
  std::deque<RenderJob>& waiting = mWaiting[sink.get()];
  if (waiting.empty()) mTurns.push_back(sink);
  waiting.push_back(std::move(job));
}

void RenderScheduler::refine(const std::shared_ptr<Sink>& sink, RenderJob job) {
  job.refinement = true;
  job.received = std::chrono::steady_clock::now();
  {
    std::lock_guard lock(mMutex);
    if (mStopping) return;
    if (auto it = mWaiting.find(sink.get()); it != mWaiting.end() && !it->second.empty()) return;
    enqueueLocked(sink, std::move(job));
  }
  mReady.notify_one();
}

RenderScheduler::GpuGauges RenderScheduler::gpu() const {
  GpuGauges out;
  for (size_t i = 0; i < mGaugeCount; ++i) {
    out.bytes += mGauges[i].bytes;
    out.peakBytes += mGauges[i].peakBytes;
    out.renderersReleased += mGauges[i].released;
  }
  return out;
}

size_t RenderScheduler::queuedSessions() const {
  std::lock_guard lock(mMutex);
  return mTurns.size();
}

void RenderScheduler::stop() {
  std::deque<std::shared_ptr<Sink>> dropped;  // released outside the lock: a session may end with it
  {
    std::lock_guard lock(mMutex);
    mStopping = true;
    dropped.swap(mTurns);
    mWaiting.clear();
  }
  mReady.notify_all();
  std::lock_guard joinLock(mJoinMutex);
  for (std::thread& thread : mThreads)
    if (thread.joinable()) thread.join();
}

bool RenderScheduler::waiting(const Sink& sink) const {
  std::lock_guard lock(mMutex);
  return mWaiting.count(&sink) != 0;
}

bool RenderScheduler::next(std::shared_ptr<Sink>& sink, RenderJob& job) {
  std::unique_lock lock(mMutex);
  mReady.wait(lock, [&] { return mStopping || !mTurns.empty(); });
  if (mStopping) return false;
  sink = std::move(mTurns.front());
  mTurns.pop_front();
  auto waiting = mWaiting.find(sink.get());
  job = std::move(waiting->second.front());
  waiting->second.pop_front();
  // Sessions take turns: one with more waiting goes to the back.
  if (waiting->second.empty())
    mWaiting.erase(waiting);
  else
    mTurns.push_back(sink);
  return true;
}

void RenderScheduler::renderLoop(std::unique_ptr<render::RenderEngine> engine, int index) {
  // A context that cannot be made current here leaves the thread answering its jobs with the error, rather than
  // ending the process from a thread or leaving requests unanswered.
  std::exception_ptr broken;
  try {
    engine->makeCurrent();
  } catch (...) {
    broken = std::current_exception();
  }
  const std::string brokenContext = "render thread " + std::to_string(index) + " cannot use its GL context";
  if (broken) errorReply(broken, brokenContext);  // logs it once now
  std::shared_ptr<Sink> sink;
  RenderJob job;
  while (next(sink, job)) {
    if (sink->wantsReplies()) {
      // Given up between batches when the session has gone, or when a refinement (whose request was answered by its
      // provisional frame) is overtaken by a newer Render of the session.
      const auto cancelled = [&] { return !sink->wantsReplies() || (job.refinement && waiting(*sink)); };
      RenderReply reply =
          broken ? RenderReply{errorReply(broken, brokenContext), false} : renderReply(*engine, job, index, cancelled);
      // The session gets its frame first; then the exact frame of a provisional one is queued, and the bricks of
      // the camera a drag would reach next are paged ahead.
      EngineGauge& gauge = mGauges[size_t(index)];
      gauge.bytes = engine->gpuBytes();
      gauge.peakBytes = engine->peakGpuBytes();
      gauge.released = engine->renderersReleased();
      if (reply.cancelled) {
        mCancelled.fetch_add(1);
        sink.reset();
        job = {};
        continue;
      }
      sink->rendered(job, std::move(reply.message));
      if (reply.provisional) refine(sink, job);
      if (!job.refinement) prefetchAhead(job);
    }
    sink.reset();
    job = {};
  }
  // The engine's renderers hold GL objects: they are destroyed here, on the thread whose context is current.
}

}  // namespace voxbrick::server
