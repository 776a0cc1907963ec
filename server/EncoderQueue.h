// The encoder threads: sessions' frames encoded off the render and I/O threads (video frames, and still frames with
// encode_aside), served by frame class as the render scheduler serves renders (ClassShares). A FIFO pool would undo
// the scheduler's order there: a tab's video frame, drawn first, would wait behind every batch client's 1024² png
// queued before it. Between classes the threads' time is shared by weight, each task charged its measured
// milliseconds; within a class first come, first served, which is round robin between sessions, since a session has
// at most one encoding at a time (Connection). Threads are kept for interactive frames while they come (one posted
// within the last second): still and batch encodings take at most the others, so a moving camera's frame never
// waits for a long encoding of a crowd's still frame to end.
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "server/FrameClass.h"

namespace voxbrick::server {

class EncoderQueue {
 public:
  using Clock = std::chrono::steady_clock;
  /// How long after an interactive task was posted threads are still kept for interactive work.
  static constexpr std::chrono::milliseconds kKeepFor{1000};

  /// `threads` (at least 1) threads; `weights` by FrameClass, each above 0 (the render scheduler's class weights);
  /// `reserved` threads kept for interactive work while it comes (at most threads - 1: none with one thread), for
  /// `keepFor` after each interactive task posted.
  EncoderQueue(size_t threads, std::array<double, kFrameClasses> weights, size_t reserved = 1,
               std::chrono::milliseconds keepFor = kKeepFor);
  /// join()s.
  ~EncoderQueue();
  EncoderQueue(const EncoderQueue&) = delete;
  EncoderQueue& operator=(const EncoderQueue&) = delete;

  /// Queues `task` in `cls`. A task must not throw; one posted after join() runs on the caller's thread.
  void post(FrameClass cls, std::function<void()> task);
  /// Runs every task queued, then stops the threads (tasks may post more meanwhile: they run too).
  void join();
  /// Tasks queued and not yet started, by class.
  std::array<size_t, kFrameClasses> queued() const;

 private:
  void work();
  /// The class to serve next among those with a task that may start now (ClassShares::pick); -1 if none.
  /// `othersMayRun` is set to whether a still or batch task may start.
  int pickLocked(Clock::time_point now, bool& othersMayRun);

  const size_t mThreadCount, mReserved;
  const std::chrono::milliseconds mKeepFor;
  mutable std::mutex mMutex;
  std::condition_variable mWake;
  std::array<std::deque<std::function<void()>>, kFrameClasses> mQueues;
  ClassShares mShares;
  std::array<size_t, kFrameClasses> mRunning{};  ///< tasks running, by class
  Clock::time_point mLastInteractive{};           ///< when an interactive task was last posted
  bool mJoining = false;
  std::vector<std::thread> mThreads;
};

}  // namespace voxbrick::server
