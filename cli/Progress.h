// A progress display for long commands: a redrawn bar on a terminal, periodic plain lines otherwise.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

namespace voxbrick::cli {

class Progress {
 public:
  /// Writes to stderr; `quiet` silences everything.
  explicit Progress(bool quiet);
  /// Shows `stage` at done/total; `bytesIn` (if > 0) gives a throughput figure.
  void update(const std::string& stage, int64_t done, int64_t total, int64_t bytesIn);
  /// For work of unknown length (a frame being drawn): nothing in its first second, then "STAGE: N s", redrawn in
  /// place on a terminal, a line every 2 s otherwise. Cheap enough to call at every checkpoint.
  void elapsed(const std::string& stage);
  /// Ends the bar line on a terminal.
  void finish();

 private:
  bool mQuiet;
  bool mTerminal;
  bool mDrawn = false;
  std::string mLastStage;
  std::chrono::steady_clock::time_point mStart, mLastLine;
};

/// Calls progress.elapsed(stage) four times a second from a thread of its own while it lives: for work that reports
/// nothing while it runs (a frame waits in the GL driver, where no checkpoint is reached). Destroy it, then call
/// progress.finish().
class ElapsedTicker {
 public:
  ElapsedTicker(Progress& progress, std::string stage);
  ~ElapsedTicker();
  ElapsedTicker(const ElapsedTicker&) = delete;
  ElapsedTicker& operator=(const ElapsedTicker&) = delete;

 private:
  std::mutex mMutex;
  std::condition_variable mWake;
  bool mDone = false;
  std::thread mThread;
};

}  // namespace voxbrick::cli
