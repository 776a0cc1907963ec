#include "server/EncoderQueue.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace voxbrick::server {

EncoderQueue::EncoderQueue(size_t threads, std::array<double, kFrameClasses> weights) : mWeights(weights) {
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
      if (queue.empty()) mTag[size_t(cls)] = std::max(mTag[size_t(cls)], mClock);
      queue.push_back(std::move(task));
      mWake.notify_one();
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

int EncoderQueue::pickLocked() const {
  int chosen = -1;
  for (size_t c = 0; c < kFrameClasses; ++c)
    if (!mQueues[c].empty() && (chosen < 0 || mTag[c] < mTag[size_t(chosen)])) chosen = int(c);
  return chosen;
}

void EncoderQueue::work() {
  std::unique_lock lock(mMutex);
  for (;;) {
    int c = -1;
    mWake.wait(lock, [&] { return (c = pickLocked()) >= 0 || mJoining; });
    if (c < 0) return;  // joining, and nothing is left
    std::function<void()> task = std::move(mQueues[size_t(c)].front());
    mQueues[size_t(c)].pop_front();
    mClock = mTag[size_t(c)];
    lock.unlock();
    const auto start = std::chrono::steady_clock::now();
    task();
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    lock.lock();
    mTag[size_t(c)] += ms / mWeights[size_t(c)];
  }
}

}  // namespace voxbrick::server
