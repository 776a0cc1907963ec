// Runs the built voxbrick binary as a child and measures what that one child cost: its peak resident memory
// (wait4's rusage, not the cumulative RUSAGE_CHILDREN) and its wall time. For the refusals of damaged inputs, which
// must be cheap.
#pragma once

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <vector>

namespace voxbrick::test {

/// How a measured child ended and what it cost.
struct MeasuredRun {
  int exitCode = -1;   ///< exit status, or 128 + signal number
  double peakMB = 0;   ///< peak resident set size, MB
  double seconds = 0;  ///< wall time
};

/// Runs VOXBRICK_EXE with `args` (no shell), its output discarded.
inline MeasuredRun runVoxbrickMeasured(const std::vector<std::string>& args) {
  std::vector<std::string> all{VOXBRICK_EXE};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    if (!freopen("/dev/null", "w", stdout) || !freopen("/dev/null", "w", stderr)) _exit(126);
    execv(argv[0], argv.data());
    _exit(127);
  }
  MeasuredRun run;
  int status = 0;
  rusage usage{};
  if (pid < 0 || wait4(pid, &status, 0, &usage) != pid) return run;
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.peakMB = double(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KB on Linux
  run.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return run;
}

}  // namespace voxbrick::test
