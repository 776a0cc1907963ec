// A progress display for long commands: a redrawn bar on a terminal, periodic plain lines otherwise.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace voxbrick::cli {

class Progress {
 public:
  /// Writes to stderr; `quiet` silences everything.
  explicit Progress(bool quiet);
  /// Shows `stage` at done/total; `bytesIn` (if > 0) gives a throughput figure.
  void update(const std::string& stage, int64_t done, int64_t total, int64_t bytesIn);
  /// Ends the bar line on a terminal.
  void finish();

 private:
  bool mQuiet;
  bool mTerminal;
  bool mDrawn = false;
  std::string mLastStage;
  std::chrono::steady_clock::time_point mStart, mLastLine;
};

}  // namespace voxbrick::cli
