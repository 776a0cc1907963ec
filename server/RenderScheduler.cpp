// The render queue: fair queueing on measured render time, by class, with shared frames; and the render threads.
#include "server/RenderScheduler.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include <spdlog/spdlog.h>

#include "common/Median.h"
#include "server/ErrorReply.h"

namespace voxbrick::server {
namespace {

using Clock = RenderScheduler::Clock;

double elapsedMs(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

/// The mean a class's frames are predicted by: an exponential average, quick to follow a change of load.
constexpr double kMeanWeight = 0.2;
constexpr double kDefaultPredictedMs = 50;
/// Moving frames the capacity is measured from (fewer: not measured yet).
constexpr uint64_t kCapacityFrames = 16;
/// The share of the threads' time the measured capacity hands out: the rest is kept for the measurement's own spread
/// (sessions taken at a high reading stay when it falls) and for sessions' uneven shares.
constexpr double kCapacityHeadroom = 0.9;

/// The retry hint of the session at `place` in line to drag (from 0): RenderScheduler::kLineStepMs for each
/// kPlacesAStep places ahead and one more, at most kLineMaxHintMs.
uint32_t lineHintMs(size_t place) {
  using S = RenderScheduler;
  return std::min(S::kLineStepMs * uint32_t(1 + std::min<size_t>(place / S::kPlacesAStep, 1000)), S::kLineMaxHintMs);
}

}  // namespace

std::string shareKeyOf(const RenderJob& job) {
  if (!job.dataset || (job.scene.progressive && !job.refinement)) return {};
  std::string key = std::to_string(reinterpret_cast<uintptr_t>(job.dataset.get()));
  key += '|' + std::to_string(int(job.encoding)) + '|' +
         (job.provisionalEncoding ? std::to_string(int(*job.provisionalEncoding)) : std::string("-")) + '|' +
         (job.refinement ? "r" : "f") + '|' + std::to_string(job.maxBodyBytes) + '|' + std::to_string(job.maxSamples) +
         '|' + (job.pngSpeed == image::PngSpeed::Fast ? "fast" : "small") + (job.webpForPng ? "|webp|" : "|") +
         (job.scene.interactive && !job.refinement
              ? std::to_string(job.outputScale) + (job.provisionalAsDrawn ? "|drawn|" : "|")
              : std::string()) +
         job.scene.toJson();
  return key;
}

RenderScheduler::RenderScheduler(std::vector<std::unique_ptr<render::FrameSource>> sources,
                                 const SchedulerConfig& config)
    : mConfig(config),
      mShares({config.interactiveWeight, config.stillWeight, config.batchWeight}),
      mSources(std::move(sources)) {
  if (mSources.empty() || !mSources.front()) throw std::invalid_argument("RenderScheduler: no frame source");
  mGaugeCount = mSources.size();
  mGauges = std::make_unique<EngineGauge[]>(mGaugeCount);
  spdlog::info("render threads: {} x {}", mSources.size(), mSources.front()->describe());
}

RenderScheduler::RenderScheduler(std::vector<std::unique_ptr<render::FrameSource>> sources, bool coalesce)
    : RenderScheduler(std::move(sources), SchedulerConfig{.coalesce = coalesce}) {}

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

double RenderScheduler::predictedMsLocked(FrameClass cls) const {
  const double mean = mClassMs[size_t(cls)];
  return mean > 0 ? mean : kDefaultPredictedMs;
}

Submission RenderScheduler::submit(const std::shared_ptr<Sink>& sink, RenderJob job) {
  Submission out;
  // The key is made once here, before the lock (it writes the scene out: a crowd's thousands of Renders a second
  // would otherwise hold the render threads' lock that long); dispatch compares it with every waiting job's.
  job.shareKey = mConfig.shareFrames ? shareKeyOf(job) : std::string();
  {
    std::lock_guard lock(mMutex);
    if (mStopping) {
      out.result = Submission::Result::Stopped;
      return out;
    }
    SessionState& state = stateLocked(sink);
    if (!job.refinement) {
      // Admission of a dragging session: a moving camera of a session not dragging until now is one more for the
      // threads to keep at min_interactive_fps, refused while as many drag as they can keep (or, before that is
      // measured, the cold bound). Decided here, under the lock that counts them, so that a crowd's first moves
      // arriving together are each counted before the next is decided.
      // Sessions refused wait in line: room that opens goes to the one refused first, not to whoever asks first.
      const auto now = Clock::now();
      if (job.scene.interactive && !state.draggingAt(job.received)) {
        // Room is held for those ahead due back soon; the hint follows the place among all ahead.
        const LineAhead ahead = lineAheadLocked(now, state.inLineAt(now) ? state.linePlace : 0);
        if (auto refusal = refuseDraggingLocked(now, ahead.due, ahead.all))
          return refuseDragLocked(state, job, now, std::move(*refusal));
        state.dragSince = job.received;
      } else if (job.scene.interactive && mConfig.interactiveTurnS > 0 &&
                 job.received - state.dragSince >= std::chrono::duration<double>(mConfig.interactiveTurnS)) {
        // A drag that held its room for a whole turn gives it up while others wait: it goes to the back of the line.
        if (const LineAhead line = lineAheadLocked(now); line.due > 0) {
          state.lastInteractive = {};
          mTurnsEnded.fetch_add(1);
          // Its drag is paused, not ended: no exact frame of its last camera (one waiting goes, and one of a frame
          // still being drawn is not queued: refine() sees a newer Render), which would cost the line a moving
          // frame's room three times over; its release asks one.
          state.lastReceived = job.received;
          if (!state.waiting.empty() && state.waiting.front().refinement) popWaitingLocked(sink.get(), state);
          return refuseDragLocked(
              state, job, now,
              Refusal{"this session's turn to drag is over (" + std::to_string(int64_t(mConfig.interactiveTurnS)) +
                          " s, interactive_turn_s): " + std::to_string(line.due) + " sessions wait to drag",
                      lineHintMs(line.all)});
        }
      }
      // Taken, or released (a still Render): its place in line goes.
      state.linePlace = 0;
      if (state.lastReceived != Clock::time_point{}) {
        state.intervalsMs.push_back(elapsedMs(state.lastReceived, job.received));
        if (state.intervalsMs.size() > kRestIntervals) state.intervalsMs.pop_front();
      }
      state.lastReceived = job.received;
      // A still frame right after a drag is the drag's last: a viewer waits for it. So is the first after a drag told
      // Busy (the session is not counted as dragging for it), within kOverCapacityHintMs (or its hint) and a second.
      job.endsDrag = !job.scene.interactive && !job.scene.batch &&
                     (state.draggingAt(job.received) || job.received <= state.refusedDragEnds);
      job.endsRefusedDrag = job.endsDrag && !state.draggingAt(job.received);
      state.refusedDragEnds = {};
      // A moving camera keeps the session dragging; a still Render ends its drag at once (a viewer's release): its
      // room goes to the next in line now, not a second later.
      state.lastInteractive = job.scene.interactive ? job.received : Clock::time_point{};
    }
    std::deque<RenderJob>& waiting = state.waiting;
    const FrameClass cls = frameClassOf(job);
    if (cls == FrameClass::Batch && (waiting.empty() || !mConfig.coalesce)) {
      // Admission: a batch job that would wait beyond the bound is refused now rather than queued without end. Its
      // expected wait: the predicted time of the batch work ahead of it, over the threads' share for batch (the
      // whole of them when no other class waits).
      const double weights = mShares.weight(FrameClass::Batch) +
                             (mWaitingByClass[0] + mRunningByClass[0] ? mShares.weight(FrameClass::Interactive) : 0) +
                             (mWaitingByClass[1] + mRunningByClass[1] ? mShares.weight(FrameClass::Still) : 0);
      const double share = mShares.weight(FrameClass::Batch) / weights;
      const double ahead = double(mWaitingByClass[size_t(FrameClass::Batch)] + 1) * predictedMsLocked(cls);
      const double waitMs = ahead / (double(mSources.size()) * share);
      if (waitMs > mConfig.batchMaxWaitMs) {
        mBusyRenders.fetch_add(1);
        out.result = Submission::Result::Busy;
        out.retryAfterMs = uint32_t(std::min(waitMs, 3600e3));
        out.why = "the server is over capacity for batch work: " +
                  std::to_string(mWaitingByClass[size_t(FrameClass::Batch)]) + " batch frames wait, about " +
                  std::to_string(int64_t(waitMs)) + " ms of render time at batch's share (limit " +
                  std::to_string(int64_t(mConfig.batchMaxWaitMs)) + " ms)";
        return out;
      }
    }
    if (!job.shareKey.empty() && waiting.empty()) {
      // The identical frame is being drawn for another session: this one rides along.
      if (auto it = mInFlight.find(job.shareKey); it != mInFlight.end()) {
        it->second.push_back({sink, std::move(job)});
        return out;
      }
    }
    if (!mConfig.coalesce && !waiting.empty() && waiting.front().refinement) {
      // An exact frame waiting for the camera to rest: the camera moved on, so it goes (silently, MessageHandler).
      out.replaced = popWaitingLocked(sink.get(), state);
      enqueueLocked(sink, std::move(job));
    } else if (mConfig.coalesce && !waiting.empty()) {
      // The one waiting job is replaced in place: the session keeps its place.
      --mWaitingByClass[size_t(frameClassOf(waiting.front()))];
      ++mWaitingByClass[size_t(cls)];
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
  SessionState& state = stateLocked(sink);
  const FrameClass cls = frameClassOf(job);
  const size_t c = size_t(cls);
  // Start-time fair queueing: a class, or a session, that had nothing waiting starts at the tag last served, so
  // time it did not use is not saved up for a burst later.
  if (mWaitingByClass[c] == 0 && mRunningByClass[c] == 0) mShares.resume(cls);
  if (state.waiting.empty()) {
    state.tag[c] = std::max(state.tag[c], mClassClock[c]);
    state.backloggedSince = ++mBacklogOrder;
    mBacklog[sink.get()] = sink;
  }
  ++mWaitingByClass[c];
  state.waiting.push_back(std::move(job));
}

RenderScheduler::SessionState& RenderScheduler::stateLocked(const std::shared_ptr<Sink>& sink) {
  auto it = mSessions.find(sink.get());
  if (it != mSessions.end() && it->second.owner.expired()) mSessions.erase(it), it = mSessions.end();
  if (it == mSessions.end()) {
    std::erase_if(mSessions, [](const auto& entry) { return entry.second.owner.expired(); });
    it = mSessions.emplace(sink.get(), SessionState{}).first;
    it->second.owner = sink;
  }
  return it->second;
}

double RenderScheduler::restMs(const Sink& sink) const {
  std::lock_guard lock(mMutex);
  const auto it = mSessions.find(&sink);
  if (it == mSessions.end() || it->second.intervalsMs.empty()) return kMaxRestMs;
  const auto& intervals = it->second.intervalsMs;
  return std::min(1.5 * *std::max_element(intervals.begin(), intervals.end()), kMaxRestMs);
}

std::optional<double> RenderScheduler::renderIntervalMs(const Sink& sink) const {
  std::lock_guard lock(mMutex);
  const auto it = mSessions.find(&sink);
  if (it == mSessions.end() || it->second.intervalsMs.empty()) return std::nullopt;
  return upperMedian({it->second.intervalsMs.begin(), it->second.intervalsMs.end()});
}

void RenderScheduler::refine(const std::shared_ptr<Sink>& sink, RenderJob job) {
  const bool rest = job.scene.interactive && !job.refinement;
  const auto asked = job.received;
  job.refinement = true;
  // The exact frame of an interactive frame is drawn once the camera rested: then it ends the drag.
  job.endsDrag = job.endsDrag || rest;
  job.received = Clock::now();
  job.notBefore = job.received;
  // The exact frame is drawn for the scene as asked: the crowd's cuts were the provisional frame's.
  if (job.requestedBudgetMs > 0) job.scene.timeBudgetMs = job.requestedBudgetMs;
  job.requestedBudgetMs = 0;
  job.provisionalJpegQuality.reset();
  job.shared = false;
  job.shareKey = mConfig.shareFrames ? shareKeyOf(job) : std::string();
  if (rest) job.notBefore += std::chrono::microseconds(int64_t(restMs(*sink) * 1000));
  {
    std::lock_guard lock(mMutex);
    if (mStopping) return;
    if (auto it = mSessions.find(sink.get()); it != mSessions.end() && !it->second.waiting.empty()) return;
    // A newer Render of the session came meanwhile, already taken by another render thread: the camera moved on,
    // and this exact frame, queued now, would overtake (and give up) the newer request's own exact frame.
    if (asked < stateLocked(sink).lastReceived) return;
    enqueueLocked(sink, std::move(job));
  }
  mReady.notify_one();
}

size_t RenderScheduler::interactiveSessionsLocked(Clock::time_point now) const {
  size_t count = 0;
  for (const auto& [key, state] : mSessions)
    if (state.draggingAt(now) && !state.owner.expired()) ++count;
  return count;
}

size_t RenderScheduler::interactiveSessions() const {
  std::lock_guard lock(mMutex);
  return interactiveSessionsLocked(Clock::now());
}

size_t RenderScheduler::interactiveCapacityLocked() const {
  if (mConfig.maxInteractiveSessions > 0) return size_t(mConfig.maxInteractiveSessions);
  // Measured: what the threads can draw at min_interactive_fps for each session, at what a moving frame costs them:
  // its own time and its share of the class's other work (the exact frames ending drags, refinements given up).
  // Over the last kCapacityWindow when it holds enough moving frames; else the moving frames' own recent mean.
  const size_t c = size_t(FrameClass::Interactive);
  if (mClassFrames[c] < kCapacityFrames || mClassMs[c] <= 0) return 0;
  const double perMovingFrameMs = mInteractiveEndsMoving >= kCapacityFrames
                                      ? std::max(mClassMs[c], mInteractiveEndsMs / double(mInteractiveEndsMoving))
                                      : mClassMs[c];
  return std::max<size_t>(
      1, size_t(kCapacityHeadroom * double(mSources.size()) * 1000 / (mConfig.minInteractiveFps * perMovingFrameMs)));
}

size_t RenderScheduler::interactiveCapacity() const {
  std::lock_guard lock(mMutex);
  return interactiveCapacityLocked();
}

Submission RenderScheduler::refuseDragLocked(SessionState& state, const RenderJob& job, Clock::time_point now,
                                             Refusal refusal) {
  if (!state.inLineAt(now)) state.linePlace = ++mLineOrder;
  state.lineDue = now + std::chrono::milliseconds(refusal.retryAfterMs);
  mLineHeldUntil = std::max(mLineHeldUntil, state.lineDue + kLineGrace);
  // Until the hint has passed (2 s at least: a viewer asks again only when the pointer moves), and a second after, the
  // session's next still Render is this drag's last (a viewer released it while waiting).
  state.refusedDragEnds =
      job.received + std::chrono::milliseconds(std::max(refusal.retryAfterMs, kOverCapacityHintMs)) + kInteractiveWindow;
  mBusyDrags.fetch_add(1);
  Submission out;
  out.result = Submission::Result::Busy;
  out.retryAfterMs = refusal.retryAfterMs;
  out.why = std::move(refusal.why);
  return out;
}

RenderScheduler::LineAhead RenderScheduler::lineAheadLocked(Clock::time_point now, uint64_t before) const {
  LineAhead out;
  if (now > mLineHeldUntil) return out;  // every place has lapsed: nobody is in line
  const auto dueBy = now + std::chrono::milliseconds(kLineStepMs);
  for (const auto& [key, state] : mSessions)
    if (state.inLineAt(now) && (before == 0 || state.linePlace < before) && !state.owner.expired()) {
      ++out.all;
      out.due += state.lineDue <= dueBy ? 1 : 0;
    }
  return out;
}

size_t RenderScheduler::waitingToDrag() const {
  std::lock_guard lock(mMutex);
  return lineAheadLocked(Clock::now()).all;
}

RenderJob RenderScheduler::popWaitingLocked(const Sink* key, SessionState& state) {
  RenderJob job = std::move(state.waiting.front());
  state.waiting.pop_front();
  --mWaitingByClass[size_t(frameClassOf(job))];
  if (state.waiting.empty()) mBacklog.erase(key);
  return job;
}

std::optional<RenderScheduler::Refusal> RenderScheduler::refuseDraggingLocked(Clock::time_point now, size_t ahead,
                                                                              std::optional<size_t> place) const {
  const size_t capacity = interactiveCapacityLocked(), dragging = interactiveSessionsLocked(now);
  const std::string inLine = ahead > 0 ? " and " + std::to_string(ahead) + " wait ahead of this one" : std::string();
  if (capacity > 0) {
    if (dragging + ahead < capacity) return std::nullopt;
    // The first in line ask again soon (room opens as a drag ends: kInteractiveWindow after its last move); those
    // behind later, a step each kPlacesAStep places.
    const uint32_t hint = place ? lineHintMs(*place) : kOverCapacityHintMs;
    return Refusal{"the server is over capacity: " + std::to_string(dragging) + " sessions are dragging" + inLine +
                       "; its render threads keep " + std::to_string(capacity) + " at their minimum rate",
                   hint};
  }
  // Not measured yet: a cold server, or the first frames of a crowd that came at once. A few sessions a thread drag
  // meanwhile; the hint is when their frames will have measured it (the frames still to come at the predicted
  // cost, over the threads), at least 100 ms and at most a second.
  const size_t cold = size_t(std::max(0, mConfig.coldInteractiveSessionsPerThread)) * mSources.size();
  if (cold == 0 || dragging + ahead < cold) return std::nullopt;
  const uint64_t measured = mClassFrames[size_t(FrameClass::Interactive)];
  const double toCome = double(measured < kCapacityFrames ? kCapacityFrames - measured : 0);
  const double hint = toCome * predictedMsLocked(FrameClass::Interactive) / double(mSources.size());
  return Refusal{"the server is measuring its capacity: " + std::to_string(dragging) + " sessions are dragging" +
                     inLine + "; it takes " + std::to_string(cold) + " before it knows what their frames cost",
                 uint32_t(std::clamp(hint, 100.0, double(kInteractiveWindow.count())))};
}

std::optional<RenderScheduler::Refusal> RenderScheduler::refuseNewSession() const {
  std::lock_guard lock(mMutex);
  return refuseDraggingLocked(Clock::now(), 0, std::nullopt);
}

void RenderScheduler::fitToLoadLocked(RenderJob& job, Clock::time_point now) const {
  // Quality yields before latency: with N sessions dragging on T threads, each gets T / N of the render time, so
  // a frame may take T * 1000 / (fps * N) ms for every session to see `fps` frames a second.
  const double share = frameShareMs(mSources.size(), mConfig.interactiveFps, interactiveSessionsLocked(now));
  const double asked = job.scene.timeBudgetMs;
  const double budget = std::clamp(share, render::SceneDelivery::kMinTimeBudgetMs, asked);
  if (budget >= asked) return;
  job.requestedBudgetMs = asked;
  job.scene.timeBudgetMs = budget;
  if (!job.scene.jpegQuality) job.provisionalJpegQuality = mConfig.loadedJpegQuality;
}

std::shared_ptr<RenderScheduler::Sink> RenderScheduler::pickLocked(Clock::time_point now,
                                                                   Clock::time_point& earliest) {
  earliest = Clock::time_point::max();
  // Still and batch frames leave reserved threads to the sessions that drag, when some do.
  const size_t threads = mSources.size();
  const size_t kept = ClassShares::kept(threads, size_t(std::max(0, mConfig.reservedInteractiveThreads)));
  const bool dragging = kept > 0 && interactiveSessionsLocked(now) > 0;
  const bool othersMayRun =
      ClassShares::othersMayRun(threads, kept, dragging, mRunningByClass[1] + mRunningByClass[2]);
  // The best due session of each class: the smallest tag, then the longest waiting.
  std::array<const Sink*, kFrameClasses> best{};
  std::array<std::pair<double, uint64_t>, kFrameClasses> bestRank{};
  for (const auto& [key, sink] : mBacklog) {
    const SessionState& state = mSessions.at(key);
    const RenderJob& front = state.waiting.front();
    if (front.notBefore > now) {
      earliest = std::min(earliest, front.notBefore);
      continue;
    }
    const size_t c = size_t(frameClassOf(front));
    if (c != size_t(FrameClass::Interactive) && !othersMayRun) continue;
    const std::pair<double, uint64_t> rank{state.tag[c], state.backloggedSince};
    if (!best[c] || rank < bestRank[c]) best[c] = key, bestRank[c] = rank;
  }
  // Between classes: by their shares of the time (ClassShares).
  std::array<bool, kFrameClasses> ready{};
  for (size_t c = 0; c < kFrameClasses; ++c) ready[c] = best[c] != nullptr;
  const int chosen = mShares.pick(ready);
  if (chosen < 0) {
    // Something may wait only for a thread its class may not take: the next finished frame wakes a thread.
    return nullptr;
  }
  return mBacklog.at(best[size_t(chosen)]);
}

void RenderScheduler::chargeLocked(const Sink* sink, FrameClass cls, double ms) {
  mShares.charge(cls, ms);
  if (auto it = mSessions.find(sink); it != mSessions.end()) it->second.tag[size_t(cls)] += ms;
}

std::array<size_t, kFrameClasses> RenderScheduler::queuedByClass() const {
  std::lock_guard lock(mMutex);
  return mWaitingByClass;
}

void RenderScheduler::EngineGauge::enter(State to, Clock::time_point now) {
  std::lock_guard lock(mTiming);
  mMs[mState] += elapsedMs(mSince, now);
  mState = to;
  mSince = now;
}

double RenderScheduler::EngineGauge::ms(State state, Clock::time_point now) const {
  std::lock_guard lock(mTiming);
  return mMs[state] + (mState == state ? elapsedMs(mSince, now) : 0.0);
}

std::vector<double> RenderScheduler::threadMs(EngineGauge::State state) const {
  const auto now = Clock::now();
  std::vector<double> out(mGaugeCount);
  for (size_t i = 0; i < mGaugeCount; ++i) out[i] = mGauges[i].ms(state, now);
  return out;
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
  return mBacklog.size();
}

void RenderScheduler::stop() {
  std::map<const Sink*, std::shared_ptr<Sink>> dropped;  // released outside the lock: a session may end with it
  {
    std::lock_guard lock(mMutex);
    mStopping = true;
    dropped.swap(mBacklog);
    for (auto& [key, state] : mSessions) state.waiting.clear();
    mSessions.clear();
    mWaitingByClass = {};
  }
  mReady.notify_all();
  std::lock_guard joinLock(mJoinMutex);
  for (std::thread& thread : mThreads)
    if (thread.joinable()) thread.join();
}

bool RenderScheduler::waiting(const Sink& sink) const {
  std::lock_guard lock(mMutex);
  return mBacklog.count(&sink) != 0;
}

bool RenderScheduler::next(Taken& taken) {
  std::unique_lock lock(mMutex);
  std::shared_ptr<Sink> sink;
  for (;;) {
    if (mStopping) return false;
    Clock::time_point earliest;
    if ((sink = pickLocked(Clock::now(), earliest))) break;
    // Nothing due: wait for a submit, a finished frame, or the first exact frame whose rest is over.
    if (earliest == Clock::time_point::max())
      mReady.wait(lock);
    else
      mReady.wait_until(lock, earliest);
  }
  SessionState& state = mSessions.at(sink.get());
  RenderJob job = popWaitingLocked(sink.get(), state);
  const FrameClass cls = frameClassOf(job);
  const size_t c = size_t(cls);
  ++mRunningByClass[c];
  mClassClock[c] = state.tag[c];
  const std::string kind(job.dataset ? job.dataset->kind() : std::string_view{});
  const render::RateGauge& rate = state.rates[kind];
  job.rateSamplesPerMs = rate.rate();
  job.fixedMs = rate.fixedMs();
  const auto now = Clock::now();
  // The key of the frame as asked (made when queued), before the crowd's cuts.
  taken.shareKey = job.shareKey;
  // The crowd's cuts are for moving cameras' frames, not for the exact frame that ends a drag.
  if (cls == FrameClass::Interactive && !job.endsDrag) fitToLoadLocked(job, now);
  taken.frameClass = cls;
  taken.charged = predictedMsLocked(cls);
  chargeLocked(sink.get(), cls, taken.charged);
  if (!taken.shareKey.empty()) {
    // Sessions waiting for the identical frame ride along: one render answers them all. A later one joins while
    // it is drawn (submit).
    std::vector<Recipient>& riders = mInFlight[taken.shareKey];
    for (auto it = mBacklog.begin(); it != mBacklog.end();) {
      SessionState& other = mSessions.at(it->first);
      if (it->first != sink.get() && other.waiting.front().notBefore <= now &&
          other.waiting.front().shareKey == taken.shareKey) {
        --mWaitingByClass[size_t(frameClassOf(other.waiting.front()))];
        riders.push_back({it->second, std::move(other.waiting.front())});
        other.waiting.pop_front();
        if (other.waiting.empty()) {
          it = mBacklog.erase(it);
          continue;
        }
      }
      ++it;
    }
  }
  taken.sink = std::move(sink);
  taken.job = std::move(job);
  return true;
}

void RenderScheduler::deliver(const Taken& taken, RenderReply& reply, std::vector<Recipient>& followers) {
  // A still frame left for its session to encode is encoded here once when others ride along, rather than once in
  // each of their sessions.
  if (reply.stillToEncode &&
      std::any_of(followers.begin(), followers.end(), [](const Recipient& r) { return r.sink->wantsReplies(); })) {
    reply.message = encodeStill(std::move(std::get<proto::Frame>(reply.message)), *reply.stillToEncode, taken.job);
    reply.stillToEncode.reset();
    reply.provisional = reply.provisional && std::holds_alternative<proto::Frame>(reply.message);
  }
  // Each follower gets the same reply under its own request id (the job carries it), marked as shared.
  for (Recipient& follower : followers) {
    if (!follower.sink->wantsReplies()) continue;
    proto::Message message = reply.message;
    if (auto* frame = std::get_if<proto::Frame>(&message)) frame->statsJson = withKey(frame->statsJson, "shared", "true");
    mShared.fetch_add(1);
    follower.job.shared = true;
    follower.sink->rendered(follower.job, std::move(message));
    if (reply.provisional) refine(follower.sink, follower.job);
  }
  if (!taken.sink->wantsReplies()) return;
  RenderJob job = taken.job;
  job.stillToEncode = reply.stillToEncode;
  job.stillProvisional = reply.stillToEncode && reply.provisional;
  taken.sink->rendered(std::move(job), std::move(reply.message));
  if (reply.provisional) refine(taken.sink, taken.job);
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
  Taken taken;
  EngineGauge& gauge = mGauges[size_t(index)];
  for (gauge.enter(EngineGauge::Waiting, Clock::now()); next(taken); gauge.enter(EngineGauge::Waiting, Clock::now())) {
    const std::shared_ptr<Sink>& sink = taken.sink;
    const RenderJob& job = taken.job;
    const auto started = Clock::now();
    gauge.enter(EngineGauge::Busy, started);
    RenderReply reply;
    bool drawn = false;
    // Whether anyone who asked for this frame still wants it (the job's own session, or one riding along).
    const auto anyoneWants = [&] {
      if (sink->wantsReplies()) return true;
      if (taken.shareKey.empty()) return false;
      std::lock_guard lock(mMutex);
      const auto it = mInFlight.find(taken.shareKey);
      return it != mInFlight.end() && std::any_of(it->second.begin(), it->second.end(),
                                                  [](const Recipient& r) { return r.sink->wantsReplies(); });
    };
    if (anyoneWants()) {
      // Given up between batches when everyone who asked has gone, or when a refinement (whose request was answered
      // by its provisional frame) is overtaken by a newer Render of the session.
      // A refinement others ride along is drawn for them even when its own session moved on.
      const auto othersRide = [&] {
        if (taken.shareKey.empty()) return false;
        std::lock_guard lock(mMutex);
        const auto it = mInFlight.find(taken.shareKey);
        return it != mInFlight.end() && !it->second.empty();
      };
      const auto cancelled = [&] {
        return !anyoneWants() || (job.refinement && waiting(*sink) && !othersRide());
      };
      reply = broken ? RenderReply{errorReply(broken, brokenContext), false}
                     : renderReply(source, job, index, cancelled);
      drawn = true;
    }
    const auto replied = Clock::now();
    // What the session is charged, and what the class's mean follows: the frame's time but its one-time work on this
    // thread's context (a renderer made for the dataset, programs built), which is no session's. The first session to
    // reach a cold thread would otherwise carry its warm-up (half a second for an atlas on llvmpipe) and wait until
    // every other session had drawn as long.
    const double ms = std::max(0.0, elapsedMs(started, replied) - reply.warmupMs);
    gauge.enter(EngineGauge::Other, replied);
    gauge.bytes = source.gpuBytes();
    gauge.peakBytes = source.peakGpuBytes();
    gauge.released = source.renderersReleased();
    std::vector<Recipient> followers;
    {
      std::lock_guard lock(mMutex);
      const size_t c = size_t(taken.frameClass);
      --mRunningByClass[c];
      if (!taken.shareKey.empty()) {
        if (auto it = mInFlight.find(taken.shareKey); it != mInFlight.end()) {
          followers = std::move(it->second);
          mInFlight.erase(it);
        }
      }
      // Charged what it took, not what was predicted, also when it was given up part way or not drawn at all: a
      // session whose exact frames are given up as it drags on would otherwise keep the class's predicted mean (a
      // crowd's 1024² still frames) for each, and wait behind the whole crowd for its next still frame.
      chargeLocked(sink.get(), taken.frameClass, ms - taken.charged);
      if (drawn && !reply.cancelled && reply.samples > 0 && job.dataset)
        stateLocked(sink).rates[std::string(job.dataset->kind())].add(reply.samples, reply.ms);
    }
    mReady.notify_all();  // a thread waiting for its class's turn may take one now
    if (drawn && reply.cancelled) mCancelled.fetch_add(1);
    if (drawn && !reply.cancelled) {
      // The sessions get their frame first; then the exact frame of a provisional one is queued, and the bricks of
      // the camera a drag would reach next are paged ahead.
      deliver(taken, reply, followers);
      if (!job.refinement) prefetchAhead(source, job);
    }
    // The thread's time after the reply (handing the frame on, paging ahead: planning the next camera's bricks) is
    // the frame's too: charged to its session, and counted in what a frame costs the threads, behind the capacity.
    const auto handed = Clock::now();
    const double after = elapsedMs(replied, handed), cost = ms + after;
    {
      std::lock_guard lock(mMutex);
      const size_t c = size_t(taken.frameClass);
      chargeLocked(sink.get(), taken.frameClass, after);
      const bool moving = drawn && !reply.cancelled && !job.endsDrag;
      // A refused drag's last frame is no cost of the drags the threads keep (RenderJob::endsRefusedDrag).
      if (taken.frameClass == FrameClass::Interactive && !job.endsRefusedDrag) {
        mInteractiveEnds.push_back({handed, cost, moving});
        mInteractiveEndsMs += cost;
        mInteractiveEndsMoving += moving ? 1 : 0;
        while (!mInteractiveEnds.empty() && handed - mInteractiveEnds.front().at > kCapacityWindow) {
          mInteractiveEndsMs -= mInteractiveEnds.front().ms;
          mInteractiveEndsMoving -= mInteractiveEnds.front().moving ? 1 : 0;
          mInteractiveEnds.pop_front();
        }
      }
      // The class's mean follows what frames drawn to the end took: the moving cameras' frames, for the interactive
      // class (its capacity is counted in them), not the exact frames ending drags.
      if (moving) {
        mClassMs[c] = mClassMs[c] > 0 ? (1 - kMeanWeight) * mClassMs[c] + kMeanWeight * cost : cost;
        ++mClassFrames[c];
      }
    }
    taken = Taken{};
  }
  gauge.enter(EngineGauge::Other, Clock::now());
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
