// Usage errors of every subcommand: exit status 1, one line on stderr naming the option, nothing on stdout.
#include <gtest/gtest.h>

#include <future>
#include <string>
#include <vector>

#include "cli/CliRun.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::lineCount;
using test::runSplit;

struct BadUsage {
  std::string args;   ///< the command line after `voxbrick`
  std::string named;  ///< what the error line must contain (the option, usually)
};

/// Every subcommand with options out of range, of the wrong kind, unknown, or missing. Commands that would run
/// (serve, load, request) are given a short time limit, so that an option wrongly accepted fails the test rather
/// than hanging it.
const std::vector<BadUsage> kBadUsage = {
    {"", "subcommand"},
    {"nonsense", "nonsense"},
    {"prep synthetic:blobs -o s --memory 0", "--memory"},
    {"prep synthetic:blobs -o s --memory 99999999", "--memory"},
    {"prep synthetic:blobs -o s --brick 6", "--brick"},
    {"prep synthetic:blobs -o s --threads -1", "--threads"},
    {"prep synthetic:blobs -o s --zstd-level 99", "--zstd-level"},
    {"prep synthetic:blobs -o s --header-bytes -5", "--header-bytes"},
    {"prep synthetic:blobs -o s --vdb-chunk -1", "--vdb-chunk"},
    {"prep synthetic:blobs -o s --tets-per-chunk 0", "--tets-per-chunk"},
    {"prep synthetic:blobs -o s --memory abc", "--memory"},
    {"prep synthetic:blobs -o s --bogus", "--bogus"},
    {"prep synthetic:blobs", "--output"},
    {"info s --brick 4", "--brick"},
    {"render s -o f.png --warm-up 101", "--warm-up"},
    {"render s -o f.png --gpu-budget 0", "--gpu-budget"},
    {"render s -o f.png --host-cache -1", "--host-cache"},
    {"render s -o f.png --host-budget 64", "'--host-budget': it is now '--host-cache'"},
    {"render s -o f.png --step 0", "--step"},
    {"render s -o f.png --fov 0", "--fov"},
    {"render s -o f.png --sub-block -1", "--sub-block"},
    {"render s -o f.png --slab -2", "--slab"},
    {"render s -o f.png --ert 2", "--ert"},
    {"render s -o f.png --lod -1", "--lod"},
    {"render s -o f.png --reference-step 0", "--reference-step"},
    {"render s -o f.png --slicer nope", "--slicer"},
    {"render s -o f.png --brick 512", "--brick"},
    {"orbit s -o f%03d.png --frames 0", "--frames"},
    {"orbit s -o f%03d.png --elevation 100", "--elevation"},
    {"orbit s -o f%03d.png --step 0", "--step"},
    {"serve --port 70000", "--port"},
    {"serve --render-threads 0", "--render-threads"},
    {"serve --idle-timeout 0", "--idle-timeout"},
    {"serve --gpu-budget 1", "--gpu-budget"},
    {"request 127.0.0.1:1 --dataset d -o f.png --timeout 0", "--timeout"},
    {"request 127.0.0.1:1 --dataset d -o f.png --step 100", "--step"},
    {"load 127.0.0.1:1 --dataset d --clients -1", "--clients"},
    {"load 127.0.0.1:1 --dataset d --duration 0", "--duration"},
    {"load 127.0.0.1:1 --dataset d --interactive 50", "--interactive"},
    {"load 127.0.0.1:1 --dataset d --drag 10 --interactive 1", "--interactive"},
    {"load 127.0.0.1:1 --dataset d --drag 10 --provisional-encoding gif", "--provisional-encoding"},
    {"compare a.png b.png --heatmap-scale 0", "--heatmap-scale"},
    {"bench --views 0", "--views"},
    {"bench --size 4", "--size"},
};

TEST(Usage, BadOptionsExitOneWithOneLineNamingTheOption) {
  // Each case is a process of its own, most of it the binary's start: four run side by side.
  const size_t n = std::size(kBadUsage);
  std::vector<test::SplitResult> results(n);
  for (size_t i = 0; i < n; i += 4) {
    std::vector<std::future<void>> batch;
    for (size_t j = i; j < std::min(n, i + 4); ++j)
      batch.push_back(std::async(std::launch::async, [&results, j] { results[j] = runSplit(kBadUsage[j].args, 20); }));
    for (auto& run : batch) run.get();
  }
  for (size_t i = 0; i < n; ++i) {
    const BadUsage& u = kBadUsage[i];
    const test::SplitResult& r = results[i];
    EXPECT_EQ(r.exitCode, 1) << "voxbrick " << u.args << "\n" << r.err;
    EXPECT_EQ(lineCount(r.err), 1) << "voxbrick " << u.args << "\n" << r.err;
    EXPECT_NE(r.err.find(u.named), std::string::npos) << "voxbrick " << u.args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("voxbrick", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(": error: "), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty()) << "voxbrick " << u.args << "\n" << r.out;
  }
}

TEST(Usage, RangesAreReadable) {
  const test::SplitResult r = runSplit("prep synthetic:blobs -o s --memory 0");
  EXPECT_EQ(r.err, "voxbrick prep: error: --memory: must be between 128 and 1048576 MB, not '0'\n");
  const test::SplitResult step = runSplit("render s -o f.png --step 0");
  EXPECT_NE(step.err.find("between 0.001 and 64 voxels"), std::string::npos) << step.err;
}

TEST(Usage, HelpAndVersionExitZero) {
  for (const std::string args : {"--help", "--version", "render --help", "prep --help", "serve --help"}) {
    const test::SplitResult r = runSplit(args);
    EXPECT_EQ(r.exitCode, 0) << args << "\n" << r.err;
    EXPECT_FALSE(r.out.empty()) << args;
  }
}

/// A store of 64³ voxels in bricks of 16, made once for the tests that render.
class SubBlock : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sDir = new test::ScratchDir;
    const test::SplitResult r = runSplit("prep synthetic:blobs,n=64 --brick 16 -q -o " + store());
    ASSERT_EQ(r.exitCode, 0) << r.err;
  }
  static void TearDownTestSuite() { delete sDir; }
  static std::string store() { return (*sDir / "blobs").string(); }
  static std::string out(const std::string& name) { return (*sDir / name).string(); }
  static test::ScratchDir* sDir;
};
test::ScratchDir* SubBlock::sDir = nullptr;

TEST_F(SubBlock, SizesThatCannotCutTheBricksAreRefused) {
  for (const std::string size : {"16", "32", "64"}) {
    const test::SplitResult r =
        runSplit("render " + store() + " -o " + out("f.png") + " --size 32x32 --sub-block " + size);
    EXPECT_EQ(r.exitCode, 1) << size << "\n" << r.err;
    EXPECT_EQ(lineCount(r.err), 1) << r.err;
    EXPECT_NE(r.err.find("--sub-block " + size), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("brick size 16"), std::string::npos) << r.err;
  }
  const test::SplitResult odd = runSplit("render " + store() + " -o " + out("f.png") + " --size 32x32 --sub-block 6");
  EXPECT_EQ(odd.exitCode, 1) << odd.err;
  EXPECT_NE(odd.err.find("power of two"), std::string::npos) << odd.err;
}

TEST_F(SubBlock, SceneLargerThanTheBrickIsRefusedAndGoodSizesRender) {
  test::writeFile(*sDir / "scene.json", std::string(R"({"sub_block": 64})"));
  const test::SplitResult r =
      runSplit("render " + store() + " -o " + out("f.png") + " --size 32x32 --scene " + out("scene.json"));
  EXPECT_EQ(r.exitCode, 1) << r.err;
  EXPECT_NE(r.err.find("sub-block 64"), std::string::npos) << r.err;
  for (const std::string size : {"0", "2", "8"}) {
    const test::SplitResult ok =
        runSplit("render -q " + store() + " -o " + out("f" + size + ".png") + " --size 32x32 --sub-block " + size);
    EXPECT_EQ(ok.exitCode, 0) << size << "\n" << ok.err;
  }
}

}  // namespace
}  // namespace voxbrick
