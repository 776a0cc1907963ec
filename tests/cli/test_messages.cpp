// The first hour's mistakes, as a user makes them with the real binary: each message names the thing, suggests the
// closest valid choice or lists the choices, and carries no internal prefix or protocol message name.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "cli/CliRun.h"
#include "server/ServerProcess.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

namespace fs = std::filesystem;
using test::runSplit;

std::string blobs() { return test::preppedStore("synthetic:blobs,n=32", "--brick 16"); }

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// No function-name prefix ("Foo::bar: "), no protocol message name, no path of the binary.
void expectPlain(const std::string& err) {
  EXPECT_FALSE(has(err, "::")) << err;
  EXPECT_FALSE(has(err, "ListDatasets")) << err;
  EXPECT_FALSE(has(err, VOXBRICK_EXE)) << err;
}

TEST(Messages, NoSubcommandListsThem) {
  const auto r = runSplit("", 30);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_TRUE(has(r.err, "voxbrick: error: a subcommand is needed: one of prep, info, render")) << r.err;
  expectPlain(r.err);
}

TEST(Messages, AMistypedSubcommandGetsTheClosest) {
  const auto r = runSplit("rendr x -o y.png", 30);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_TRUE(has(r.err, "no subcommand 'rendr'; did you mean 'render'?")) << r.err;
  EXPECT_TRUE(has(r.err, "serve")) << "the choices are listed: " << r.err;
  expectPlain(r.err);
}

TEST(Messages, AnUnknownOptionIsNamedFirst) {
  test::ScratchDir dir;
  const auto r = runSplit("render " + blobs() + " --transfer mri -o " + (dir / "x.png").string(), 30);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_TRUE(has(r.err, "voxbrick render: error: unknown option '--transfer'")) << r.err;
  EXPECT_TRUE(has(r.err, "voxbrick render --help lists the options")) << r.err;
  EXPECT_FALSE(has(r.err, "were not expected")) << r.err;
  const auto close = runSplit("render " + blobs() + " --sise 64x64 -o " + (dir / "x.png").string(), 30);
  EXPECT_TRUE(has(close.err, "unknown option '--sise'; did you mean '--size'?")) << close.err;
}

TEST(Messages, UsageLinesSayVoxbrickNotThePathOfTheBinary) {
  const auto r = runSplit("render --help", 30);
  EXPECT_EQ(r.exitCode, 0);
  EXPECT_TRUE(has(r.out, "Usage: voxbrick render")) << r.out;
  EXPECT_FALSE(has(r.out, VOXBRICK_EXE)) << r.out;
}

TEST(Messages, PresetsAreFoundButForCaseAndSuggestedWhenMistyped) {
  test::ScratchDir dir;
  const auto upper = runSplit("render -q " + blobs() + " --size 32x32 --tf MRI -o " + (dir / "a.png").string(), 120);
  EXPECT_EQ(upper.exitCode, 0) << "a preset named but for case is the preset: " << upper.err;
  const auto typo = runSplit("render -q " + blobs() + " --size 32x32 --tf mrri -o " + (dir / "b.png").string(), 120);
  EXPECT_EQ(typo.exitCode, 1);
  EXPECT_TRUE(has(typo.err, "no preset 'mrri'")) << typo.err;
  EXPECT_TRUE(has(typo.err, "did you mean 'mri'?")) << typo.err;
  EXPECT_TRUE(has(typo.err, "presets: ")) << typo.err;
  expectPlain(typo.err);
}

TEST(Messages, AnUnknownDatasetGetsTheServersListAndTheClosest) {
  test::ScratchDir dir;
  fs::create_directories(dir / "datasets");
  fs::copy(blobs(), dir / "datasets" / "blobs.vbs", fs::copy_options::recursive);
  test::ServerProcess server("--no-config --datasets " + (dir / "datasets").string() + " --render-threads 1",
                             dir.path());
  const std::string address = "127.0.0.1:" + std::to_string(server.port());
  const auto r = runSplit("request " + address + " --dataset blobs --size 32x32 -o " + (dir / "x.png").string(), 60);
  EXPECT_NE(r.exitCode, 0);
  EXPECT_TRUE(has(r.err, "no dataset 'blobs'; did you mean 'blobs.vbs'? (one of: blobs.vbs)")) << r.err;
  expectPlain(r.err);
  const auto ok =
      runSplit("request " + address + " --dataset blobs.vbs --size 32x32 -o " + (dir / "y.png").string(), 60);
  EXPECT_EQ(ok.exitCode, 0) << ok.err;
}

TEST(Messages, AMissingPathIsReportedTheSameWayByEveryCommand) {
  test::ScratchDir dir;
  const std::string missing = (dir / "data" / "mri.vb").string();
  for (const std::string& command : {"prep " + missing + " -o " + (dir / "s").string(), "info " + missing,
                                     "render " + missing + " -o " + (dir / "x.png").string()}) {
    const auto r = runSplit(command, 60);
    EXPECT_EQ(r.exitCode, 1) << command;
    EXPECT_TRUE(has(r.err, ": error: " + missing + ": no such file or directory")) << command << ": " << r.err;
    expectPlain(r.err);
  }
}

}  // namespace
}  // namespace voxbrick
