// The latest-wins queue and the render threads.
#include "server/RenderScheduler.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>
#include <functional>
#include <string_view>

#include <spdlog/spdlog.h>

#include "server/ErrorReply.h"
#include "server/ServerConfig.h"

namespace voxbrick::server {

RenderScheduler::RenderScheduler(std::vector<std::unique_ptr<render::FrameSource>> sources, bool coalesce)
    : mCoalesce(coalesce), mSources(std::move(sources)) {
  if (mSources.empty() || !mSources.front()) throw std::invalid_argument("RenderScheduler: no frame source");
  mGaugeCount = mSources.size();
  mGauges = std::make_unique<EngineGauge[]>(mGaugeCount);
  spdlog::info("render threads: {} x {}", mSources.size(), mSources.front()->describe());
}

void RenderScheduler::start() {
  try {
    std::lock_guard joinLock(mJoinMutex);
    for (size_t i = 0; i < mSources.size(); ++i)
      mThreads.emplace_back(&RenderScheduler::renderLoop, this, std::ref(*mSources[i]), int(i));
  } catch (...) {
    stop();  // the threads already started must not outlive a failed start
    throw;
  }
}

RenderScheduler::~RenderScheduler() {
  stop();
  // A source holds GL objects: each is made current here, on the one thread left, while it is destroyed.
  for (auto& source : mSources) {
    try {
      source->makeCurrent();
    } catch (...) {
      // A context that cannot be made current is destroyed as it is.
    }
    source.reset();
  }
}

void RenderScheduler::checkDataset(const std::string& name) {
  for (const auto& source : mSources) source->checkDataset(name);
}

Submission RenderScheduler::submit(const std::shared_ptr<Sink>& sink, RenderJob job) {
  Submission out;
  {
    std::lock_guard lock(mMutex);
    if (mStopping) {
      out.result = Submission::Result::Stopped;
      return out;
    }
    SessionPace& pace = paceLocked(sink);
    if (!job.refinement) {
      if (pace.lastReceived != std::chrono::steady_clock::time_point{})
        pace.intervalMs = std::chrono::duration<double, std::milli>(job.received - pace.lastReceived).count();
      pace.lastReceived = job.received;
    }
    std::deque<RenderJob>& waiting = mWaiting[sink.get()];
    if (!mCoalesce && !waiting.empty() && waiting.front().refinement) {
      // An exact frame waiting for the camera to rest: the camera moved on, so it goes (silently, MessageHandler).
      out.replaced = std::move(waiting.front());
      waiting.pop_front();
      if (waiting.empty()) {
        mWaiting.erase(sink.get());
        std::erase(mTurns, sink);
      }
      enqueueLocked(sink, std::move(job));
    } else if (mCoalesce && !waiting.empty()) {
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

RenderScheduler::SessionPace& RenderScheduler::paceLocked(const std::shared_ptr<Sink>& sink) {
  auto it = mPaces.find(sink.get());
  if (it != mPaces.end() && it->second.owner.expired()) mPaces.erase(it), it = mPaces.end();
  if (it == mPaces.end()) {
    std::erase_if(mPaces, [](const auto& entry) { return entry.second.owner.expired(); });
    it = mPaces.emplace(sink.get(), SessionPace{}).first;
    it->second.owner = sink;
  }
  return it->second;
}

double RenderScheduler::restMs(const Sink& sink) const {
  std::lock_guard lock(mMutex);
  const auto it = mPaces.find(&sink);
  if (it == mPaces.end() || it->second.intervalMs <= 0) return kMaxRestMs;
  return std::min(1.5 * it->second.intervalMs, kMaxRestMs);
}

void RenderScheduler::refine(const std::shared_ptr<Sink>& sink, RenderJob job) {
  const bool rest = job.scene.interactive && !job.refinement;
  const auto asked = job.received;
  job.refinement = true;
  job.received = std::chrono::steady_clock::now();
  job.notBefore = job.received;
  if (rest) job.notBefore += std::chrono::microseconds(int64_t(restMs(*sink) * 1000));
  {
    std::lock_guard lock(mMutex);
    if (mStopping) return;
    if (auto it = mWaiting.find(sink.get()); it != mWaiting.end() && !it->second.empty()) return;
    // A newer Render of the session came meanwhile, already taken by another render thread: the camera moved on,
    // and this exact frame, queued now, would overtake (and give up) the newer request's own exact frame.
    if (asked < paceLocked(sink).lastReceived) return;
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

std::array<size_t, kFrameClasses> RenderScheduler::queuedByClass() const {
  std::array<size_t, kFrameClasses> out{};
  std::lock_guard lock(mMutex);
  for (const auto& [sink, jobs] : mWaiting)
    for (const RenderJob& job : jobs) ++out[size_t(frameClassOf(job))];
  return out;
}

std::vector<double> RenderScheduler::deviceBusyMs() const {
  std::vector<double> out(mGaugeCount);
  for (size_t i = 0; i < mGaugeCount; ++i) out[i] = mGauges[i].busyMs.load();
  return out;
}

void RenderScheduler::stop() {
  std::deque<std::shared_ptr<Sink>> dropped;  // released outside the lock: a session may end with it
  {
    std::lock_guard lock(mMutex);
    mStopping = true;
    dropped.swap(mTurns);
    mWaiting.clear();
    mPaces.clear();
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

std::shared_ptr<RenderScheduler::Sink> RenderScheduler::takeDueLocked(std::chrono::steady_clock::time_point& earliest) {
  const auto now = std::chrono::steady_clock::now();
  earliest = std::chrono::steady_clock::time_point::max();
  for (auto it = mTurns.begin(); it != mTurns.end(); ++it) {
    const auto due = mWaiting.at(it->get()).front().notBefore;
    if (due <= now) {
      std::shared_ptr<Sink> sink = std::move(*it);
      mTurns.erase(it);
      return sink;
    }
    earliest = std::min(earliest, due);
  }
  return nullptr;
}

bool RenderScheduler::next(std::shared_ptr<Sink>& sink, RenderJob& job) {
  std::unique_lock lock(mMutex);
  for (;;) {
    if (mStopping) return false;
    std::chrono::steady_clock::time_point earliest;
    if ((sink = takeDueLocked(earliest))) break;
    // Nothing due: wait for a submit, or for the first exact frame whose rest is over.
    if (earliest == std::chrono::steady_clock::time_point::max())
      mReady.wait(lock);
    else
      mReady.wait_until(lock, earliest);
  }
  const std::string kind(mWaiting.at(sink.get()).front().dataset ? mWaiting.at(sink.get()).front().dataset->kind()
                                                                  : std::string_view{});
  auto waiting = mWaiting.find(sink.get());
  job = std::move(waiting->second.front());
  waiting->second.pop_front();
  const render::RateGauge& rate = paceLocked(sink).rates[kind];
  job.rateSamplesPerMs = rate.rate();
  job.fixedMs = rate.fixedMs();
  // Sessions take turns: one with more waiting goes to the back.
  if (waiting->second.empty())
    mWaiting.erase(waiting);
  else
    mTurns.push_back(sink);
  return true;
}

void RenderScheduler::renderLoop(render::FrameSource& source, int index) {
  // A context that cannot be made current here leaves the thread answering its jobs with the error, rather than
  // ending the process from a thread or leaving requests unanswered.
  std::exception_ptr broken;
  try {
    source.makeCurrent();
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
      const auto started = std::chrono::steady_clock::now();
      RenderReply reply =
          broken ? RenderReply{errorReply(broken, brokenContext), false} : renderReply(source, job, index, cancelled);
      // The session gets its frame first; then the exact frame of a provisional one is queued, and the bricks of
      // the camera a drag would reach next are paged ahead.
      EngineGauge& gauge = mGauges[size_t(index)];
      gauge.busyMs = gauge.busyMs.load() +
                     std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
      gauge.bytes = source.gpuBytes();
      gauge.peakBytes = source.peakGpuBytes();
      gauge.released = source.renderersReleased();
      if (reply.cancelled) {
        mCancelled.fetch_add(1);
        sink.reset();
        job = {};
        continue;
      }
      if (reply.samples > 0 && job.dataset) {
        std::lock_guard lock(mMutex);
        paceLocked(sink).rates[std::string(job.dataset->kind())].add(reply.samples, reply.ms);
      }
      sink->rendered(job, std::move(reply.message));
      if (reply.provisional) refine(sink, job);
      if (!job.refinement) prefetchAhead(source, job);
    }
    sink.reset();
    job = {};
  }
  // The source stays with the scheduler (its destructor destroys it): released here, so that it may be taken there.
  if (!broken) {
    try {
      source.releaseCurrent();
    } catch (...) {
      // Nothing more to draw with it.
    }
  }
}

}  // namespace voxbrick::server
