// Progress display. Plain lines are rate-limited so that logs of a CI run or a batch job stay short.
#include "cli/Progress.h"

#include <unistd.h>

#include <cstdio>

namespace voxbrick::cli {

Progress::Progress(bool quiet)
    : mQuiet(quiet),
      mTerminal(isatty(STDERR_FILENO) != 0),
      mStart(std::chrono::steady_clock::now()),
      mLastLine(mStart) {}

void Progress::update(const std::string& stage, int64_t done, int64_t total, int64_t bytesIn) {
  if (mQuiet || total <= 0) return;
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - mStart).count();
  const double fraction = double(done) / double(total);
  char rate[64] = "";
  if (bytesIn > 0 && elapsed > 0) std::snprintf(rate, sizeof rate, "  %.1f MB/s in", bytesIn / 1e6 / elapsed);
  if (mTerminal) {
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(static_cast<size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::fprintf(stderr, "\r%-8s [%s] %5.1f%%%s   ", stage.c_str(), bar.c_str(), 100 * fraction, rate);
    std::fflush(stderr);
    mDrawn = true;
    return;
  }
  const bool stageChanged = stage != mLastStage;
  if (stageChanged || done == total || now - mLastLine >= std::chrono::seconds(2)) {
    std::fprintf(stderr, "%s: %lld/%lld (%.0f%%)%s\n", stage.c_str(), static_cast<long long>(done),
                 static_cast<long long>(total), 100 * fraction, rate);
    mLastLine = now;
    mLastStage = stage;
  }
}

void Progress::elapsed(const std::string& stage) {
  if (mQuiet) return;
  const auto now = std::chrono::steady_clock::now();
  const double seconds = std::chrono::duration<double>(now - mStart).count();
  if (seconds < 1) return;
  if (mTerminal) {
    if (now - mLastLine < std::chrono::milliseconds(250)) return;
    std::fprintf(stderr, "\r%s: %.0f s   ", stage.c_str(), seconds);
    std::fflush(stderr);
    mDrawn = true;
  } else {
    if (mLastStage == stage && now - mLastLine < std::chrono::seconds(2)) return;
    std::fprintf(stderr, "%s: %.0f s\n", stage.c_str(), seconds);
    mLastStage = stage;
  }
  mLastLine = now;
}

ElapsedTicker::ElapsedTicker(Progress& progress, std::string stage)
    : mThread([this, &progress, stage = std::move(stage)] {
        std::unique_lock lock(mMutex);
        while (!mWake.wait_for(lock, std::chrono::milliseconds(250), [this] { return mDone; })) progress.elapsed(stage);
      }) {}

ElapsedTicker::~ElapsedTicker() {
  {
    std::lock_guard lock(mMutex);
    mDone = true;
  }
  mWake.notify_one();
  mThread.join();
}

void Progress::finish() {
  if (mDrawn) std::fprintf(stderr, "\n");
  mDrawn = false;
}

}  // namespace voxbrick::cli
