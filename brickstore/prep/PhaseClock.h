// Wall and CPU time of a stretch of work, for prep's account of where its time goes.
#pragma once

#include <sys/resource.h>

#include <chrono>
#include <string>

namespace voxbrick::store {

/// Wall seconds and the process's CPU seconds (user + system, all threads) a phase took.
struct PhaseTime {
  std::string name;
  double wallSeconds = 0;
  double cpuSeconds = 0;
};

/// Measures from construction (or restart()) to elapsed(); CPU time is the whole process's, so a phase timed while
/// other work runs beside it is charged that work too.
class PhaseClock {
 public:
  PhaseClock() { restart(); }
  void restart() {
    mWall = std::chrono::steady_clock::now();
    mCpu = processCpuSeconds();
  }
  /// {wall, cpu} seconds since the start.
  PhaseTime elapsed(std::string name) const {
    return {std::move(name), std::chrono::duration<double>(std::chrono::steady_clock::now() - mWall).count(),
            processCpuSeconds() - mCpu};
  }
  static double processCpuSeconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  }

 private:
  std::chrono::steady_clock::time_point mWall;
  double mCpu = 0;
};

}  // namespace voxbrick::store
