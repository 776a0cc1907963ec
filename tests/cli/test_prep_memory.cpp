// `prep --memory MB` bounds the whole process's peak resident memory, measured on the child by wait4.
#include <gtest/gtest.h>

#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <cmath>
#include <string>
#include <vector>

#include "support/TestSupport.h"

extern char** environ;

namespace voxbrick {
namespace {

/// Runs the binary with `args` (no shell) and returns its peak resident memory in MB; fails the test if it does
/// not exit 0.
double peakRssMB(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  std::string exe = VOXBRICK_EXE;
  argv.push_back(exe.data());
  std::vector<std::string> copy = args;
  for (std::string& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  EXPECT_EQ(posix_spawn(&pid, exe.c_str(), nullptr, nullptr, argv.data(), environ), 0);
  int status = 0;
  rusage usage{};
  EXPECT_EQ(wait4(pid, &status, 0, &usage), pid);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "status " << status;
  return double(usage.ru_maxrss) / 1024;  // kilobytes on Linux
}

TEST(PrepMemory, PeakResidentMemoryStaysWithinTheBudget) {
  // The process before any buffer: prep counts 112 MB for it.
  const double idle = peakRssMB({"--version"});
  EXPECT_LT(idle, 112) << "the idle process outgrew what prep counts for it (StoreWriter.cpp, kBaselineBytes)";
  test::ScratchDir dir;
  for (const int budget : {152, 208}) {
    const std::string out = (dir / ("s" + std::to_string(budget))).string();
    const double peak =
        peakRssMB({"prep", "synthetic:blobs,n=256", "--memory", std::to_string(budget), "-q", "-o", out});
    EXPECT_LE(peak, budget) << "--memory " << budget << " (idle process " << idle << " MB)";
    EXPECT_GT(peak, idle) << "the measurement sees the work";
  }
}

// A raw float file is read again for its histogram and level 1 made in level 0's pass (spilled to a scratch file in
// the page cache): the bound holds for that path too.
TEST(PrepMemory, RawFloatInputStaysWithinTheBudget) {
  test::ScratchDir dir;
  constexpr int kN = 256;
  std::vector<float> values(size_t(kN) * kN * kN);
  for (size_t n = 0; n < values.size(); ++n) values[n] = std::sin(float(n % 9973) * 0.01f) * float(n % 7);
  test::writeFile(dir / "v.raw", values.data(), values.size() * sizeof(float));
  values = {};
  for (const int budget : {152, 208}) {
    const std::string out = (dir / ("s" + std::to_string(budget))).string();
    const double peak = peakRssMB({"prep", (dir / "v.raw").string(), "--dims", "256,256,256", "--type", "f32",
                                   "--memory", std::to_string(budget), "-q", "-o", out});
    EXPECT_LE(peak, budget) << "--memory " << budget;
  }
}

}  // namespace
}  // namespace voxbrick
