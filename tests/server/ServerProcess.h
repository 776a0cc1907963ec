// The real `voxbrick serve` process for tests: started on a free port, stopped with a signal, its log kept.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "support/TestSupport.h"

namespace voxbrick::test {

class ServerProcess {
 public:
  /// Starts `voxbrick serve --port 0 --port-file ... <args>` and waits (up to 60 s) until it listens (on its HTTP
  /// port too when `args` has --http PORT).
  /// Throws std::runtime_error with the log if it exits or does not listen in time.
  ServerProcess(const std::string& args, const std::filesystem::path& scratch);
  /// Kills the process if it still runs.
  ~ServerProcess();
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  int port() const { return mPort; }
  /// The HTTP port (args with --http), else 0.
  int httpPort() const { return mHttpPort; }
  pid_t pid() const { return mPid; }
  bool running();
  /// Sends `signal` and waits up to `timeout` for the exit; returns the exit status, 128 + signal if killed by
  /// one, or -1 if it did not exit in time (it is then killed).
  int stop(int signal, std::chrono::milliseconds timeout = std::chrono::seconds(20));
  /// Resident memory now, from /proc (0 once it exited).
  uint64_t residentBytes() const;
  std::string log() const;

 private:
  pid_t mPid = -1;
  int mPort = 0, mHttpPort = 0;
  int mStatus = -1;
  std::filesystem::path mLog;
};

/// Suites of the real server over one directory of stores, made once per suite: a sparse synthetic field (64³) in
/// bricks of 16, named "sparse".
class SparseDatasetSuite : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sDir = new ScratchDir();
    std::filesystem::create_directories(*sDir / "datasets");
    const auto r =
        runVoxbrick("prep synthetic:sparse,n=64 --brick 16 --no-vdb -q -o " + (*sDir / "datasets" / "sparse").string());
    ASSERT_EQ(r.exitCode, 0) << r.output;
  }
  static void TearDownTestSuite() {
    delete sDir;
    sDir = nullptr;
  }
  static std::string datasets() { return (*sDir / "datasets").string(); }
  static std::filesystem::path scratch() { return sDir->path(); }
  /// `voxbrick serve` of the suite's stores, with `args` besides (e.g. "--render-threads 1").
  static std::unique_ptr<ServerProcess> serve(const std::string& args) {
    return std::make_unique<ServerProcess>("--datasets " + datasets() + " " + args, scratch());
  }

  static inline ScratchDir* sDir = nullptr;
};

}  // namespace voxbrick::test
