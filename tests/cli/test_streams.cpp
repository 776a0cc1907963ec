// What goes where: results on stdout, logs, progress and warnings on stderr.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "cli/CliRun.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::lineCount;
using test::runSplit;

TEST(Streams, ServerLogsGoToStderrAndStdoutHasOnlyTheAddress) {
  test::ScratchDir dir;
  std::filesystem::create_directories(dir / "datasets");
  // Once it says where it listens, SIGTERM, which the server takes as a request to stop; it must then have ended
  // of itself (status 0), its streams complete.
  const std::string out = (dir / "out").string(), err = (dir / "err").string();
  const test::CommandResult run = test::runShell(
      std::string(VOXBRICK_EXE) + " serve --port 0 --log-level info --datasets " + (dir / "datasets").string() +
      " </dev/null >" + out + " 2>" + err + " & pid=$!; for i in $(seq 1200); do grep -q listening " + out +
      " && break; sleep 0.05; done; kill -TERM $pid; wait $pid");
  EXPECT_EQ(run.exitCode, 0) << run.output;
  const std::vector<char> o = test::readFile(out), e = test::readFile(err);
  const std::string stdoutText(o.begin(), o.end()), stderrText(e.begin(), e.end());
  EXPECT_EQ(lineCount(stdoutText), 1) << stdoutText;
  EXPECT_EQ(stdoutText.rfind("listening on 127.0.0.1:", 0), 0u) << stdoutText;
  EXPECT_NE(stderrText.find("serving datasets from"), std::string::npos) << stderrText;
  EXPECT_NE(stderrText.find("[info]"), std::string::npos) << stderrText;
}

TEST(Streams, PrepWarningsGoToStderrAndResultsToStdout) {
  test::ScratchDir dir;
  std::vector<float> v(4 * 4 * 4, 1.0f);
  v[5] = std::numeric_limits<float>::quiet_NaN();
  test::writeFile(dir / "v.raw", v.data(), v.size() * sizeof(float));
  const test::SplitResult r =
      runSplit("prep " + (dir / "v.raw").string() + " --dims 4,4,4 --type f32 --brick 8 -q -o " + (dir / "s").string());
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("non-finite voxels: 1 "), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("non-finite"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("prep: wrote"), std::string::npos) << r.out;
}

TEST(Streams, RenderPrintsItsRendererOnStderrAndItsResultOnStdout) {
  test::ScratchDir dir;
  const std::string store = test::preppedStore("synthetic:blobs,n=64", "--brick 16");
  const test::SplitResult r = runSplit("render " + store + " --size 32x32 -o " + (dir / "f.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(lineCount(r.out), 1) << r.out;
  EXPECT_EQ(r.out.rfind("render: wrote", 0), 0u) << r.out;
  EXPECT_NE(r.err.find("render: "), std::string::npos) << r.err;
}

TEST(Streams, FramesPastASecondShowProgressOnStderr) {
  test::ScratchDir dir;
  const std::string store = test::preppedStore("synthetic:blobs,n=64", "--brick 16");
  // hot is transparent only at 0, so every brick of the blobs is drawn (the default grayscale skips the corners,
  // which makes the frame too quick to show progress).
  const std::string slow = "render " + store + " --size 64x64 --step 0.001 --tf hot -o " + (dir / "slow.png").string();
  const test::SplitResult r = runSplit(slow);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("render: drawing 64x64: 1 s\n"), std::string::npos) << r.err;
  EXPECT_EQ(lineCount(r.out), 1) << r.out;
  const test::SplitResult quiet = runSplit(slow + " -q");
  ASSERT_EQ(quiet.exitCode, 0) << quiet.err;
  EXPECT_TRUE(quiet.err.empty()) << quiet.err;
  const test::SplitResult fast = runSplit("render " + store + " --size 32x32 -o " + (dir / "fast.png").string());
  ASSERT_EQ(fast.exitCode, 0) << fast.err;
  EXPECT_EQ(fast.err.find("drawing"), std::string::npos) << fast.err;
}

}  // namespace
}  // namespace voxbrick
