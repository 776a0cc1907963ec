#include "server/EncoderQueue.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace voxbrick::server {

EncoderQueue::EncoderQueue(size_t threads, std::array<double, kFrameClasses> weights, size_t reserved,
                           std::chrono::milliseconds keepFor)
    : mThreadCount(threads), mReserved(ClassShares::kept(threads, reserved)), mKeepFor(keepFor), mShares(weights) {
  if (threads == 0) throw std::invalid_argument("EncoderQueue: no threads");
  for (double w : weights)
    if (!(w > 0)) throw std::invalid_argument("EncoderQueue: a class weight is not above 0");
  mThreads.reserve(threads);
  for (size_t i = 0; i < threads; ++i) mThreads.emplace_back([this] { work(); });
}

EncoderQueue::~EncoderQueue() { join(); }

void EncoderQueue::post(FrameClass cls, std::function<void()> task) {
  {
    std::lock_guard lock(mMutex);
    if (!(mJoining && mThreads.empty())) {
      auto& queue = mQueues[size_t(cls)];
      if (queue.empty()) mShares.resume(cls);
      queue.push_back(std::move(task));
      if (cls == FrameClass::Interactive) mLastInteractive = Clock::now();
      // Every thread: the one free may be one that only interactive work may take.
      mWake.notify_all();
      return;
    }
  }
  task();  // joined: no thread is left to run it
}

void EncoderQueue::join() {
  std::vector<std::thread> threads;
  {
    std::lock_guard lock(mMutex);
    mJoining = true;
    mWake.notify_all();
    threads.swap(mThreads);
  }
  for (auto& t : threads) t.join();
}

std::array<size_t, kFrameClasses> EncoderQueue::queued() const {
  std::lock_guard lock(mMutex);
  std::array<size_t, kFrameClasses> counts{};
  for (size_t c = 0; c < kFrameClasses; ++c) counts[c] = mQueues[c].size();
  return counts;
}

int EncoderQueue::pickLocked(Clock::time_point now, bool& othersMayRun) {
  // Still and batch work leaves the reserved threads to interactive work while it comes (not while joining).
  const bool keeping = mReserved > 0 && !mJoining && now - mLastInteractive < mKeepFor;
  othersMayRun = ClassShares::othersMayRun(mThreadCount, mReserved, keeping,
                                           mRunning[size_t(FrameClass::Still)] + mRunning[size_t(FrameClass::Batch)]);
  std::array<bool, kFrameClasses> ready{};
  for (size_t c = 0; c < kFrameClasses; ++c)
    ready[c] = !mQueues[c].empty() && (c == size_t(FrameClass::Interactive) || othersMayRun);
  return mShares.pick(ready);
}

void EncoderQueue::work() {
  std::unique_lock lock(mMutex);
  for (;;) {
    bool othersMayRun = true;
    const int c = pickLocked(Clock::now(), othersMayRun);
    if (c < 0) {
      const bool anything = std::any_of(mQueues.begin(), mQueues.end(), [](const auto& q) { return !q.empty(); });
      if (mJoining && !anything) return;
      // Work held back only by the reserve waits until a task ends, interactive work comes, or the reserve lapses.
      if (anything && !othersMayRun)
        mWake.wait_until(lock, mLastInteractive + mKeepFor);
      else
        mWake.wait(lock);
      continue;
    }
    std::function<void()> task = std::move(mQueues[size_t(c)].front());
    mQueues[size_t(c)].pop_front();
    ++mRunning[size_t(c)];
    lock.unlock();
    const auto start = Clock::now();
    task();
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    lock.lock();
    --mRunning[size_t(c)];
    mShares.charge(FrameClass(c), ms);
    mWake.notify_all();  // a thread held back by the reserve may take work now
  }
}

}  // namespace voxbrick::server
