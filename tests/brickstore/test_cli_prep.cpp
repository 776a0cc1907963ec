// `voxbrick prep` and `voxbrick info` as a user runs them: real process, real files, exit codes and messages.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <vector>

#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::runShell;
using test::runVoxbrick;
using test::ScratchDir;

/// Only the named entries remain in `dir` (no temporary or half-written store).
void expectOnly(const std::filesystem::path& dir, std::vector<std::string> names) {
  std::vector<std::string> found;
  for (auto& e : std::filesystem::directory_iterator(dir)) found.push_back(e.path().filename().string());
  std::sort(found.begin(), found.end());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(found, names);
}

void expectError(const test::CommandResult& r, const std::vector<std::string>& words) {
  EXPECT_EQ(r.exitCode, 1) << r.output;
  for (const std::string& w : words)
    EXPECT_NE(r.output.find(w), std::string::npos) << "missing '" << w << "' in:\n" << r.output;
  // One clear line, not a stack of them.
  EXPECT_LE(std::count(r.output.begin(), r.output.end(), '\n'), 2) << r.output;
}

TEST(CliPrep, RawRoundTripAndInfoJson) {
  ScratchDir dir;
  std::vector<uint16_t> v(30 * 20 * 10);
  for (size_t i = 0; i < v.size(); ++i) v[i] = uint16_t(i % 1000);
  test::writeFile(dir / "v.raw", v.data(), v.size() * 2);
  auto r = runVoxbrick("prep " + (dir / "v.raw").string() + " --dims 30,20,10 --type u16 --spacing 1,1,2.5 " +
                       "--brick 8 -q -o " + (dir / "s").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("MB/s in"), std::string::npos) << r.output;

  r = runVoxbrick("info --json " + (dir / "s").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["dims"], nlohmann::json({30, 20, 10}));
  EXPECT_EQ(j["spacing"], nlohmann::json({1.0, 1.0, 2.5}));
  EXPECT_EQ(j["type"], "u16");
  EXPECT_EQ(j["value_range"], nlohmann::json({0.0, 999.0}));
  EXPECT_EQ(j["brick_size"], 8);
  ASSERT_EQ(j["levels"].size(), 3u);
  EXPECT_EQ(j["levels"][0]["dims"], nlohmann::json({30, 20, 10}));
  EXPECT_EQ(j["levels"][0]["bricks_total"], 4 * 3 * 2);
  EXPECT_EQ(j["levels"][0]["bricks_stored"], 4 * 3 * 2);
  EXPECT_EQ(j["bytes_raw"], 30 * 20 * 10 * 2);
  EXPECT_GT(j["bytes_stored"].get<int64_t>(), 0);
  uint64_t counted = 0;
  for (auto& c : j["histogram"]["counts"]) counted += c.get<uint64_t>();
  EXPECT_EQ(counted, v.size());

  r = runVoxbrick("info " + (dir / "s").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("30x20x10"), std::string::npos) << r.output;
}

TEST(CliPrep, BadRawInputsNameTheFileAndProblem) {
  ScratchDir dir;
  std::vector<char> bytes(1000, 1);
  test::writeFile(dir / "v.raw", bytes.data(), bytes.size());
  const std::string in = (dir / "v.raw").string(), out = " -q -o " + (dir / "s").string();
  expectError(runVoxbrick("prep " + in + " --dims 10,10,11 --type u8" + out), {"v.raw", "1000", "1100"});
  expectError(runVoxbrick("prep " + in + " --dims 10,0,10 --type u8" + out), {"dims"});
  expectError(runVoxbrick("prep " + in + " --dims 10,10,10 --type u64" + out), {"u64"});
  expectError(runVoxbrick("prep " + in + " --dims 10,10 --type u8" + out), {"--dims"});
  expectError(runVoxbrick("prep " + (dir / "nope.raw").string() + " --dims 1,1,1 --type u8" + out),
              {"nope.raw", "no such file"});
  expectError(runVoxbrick("prep " + in + " --dims 10,10,10 --type u8 --brick 6" + out), {"--brick"});
  expectError(runVoxbrick("prep synthetic:nonsense" + out), {"nonsense"});
  expectOnly(dir.path(), {"v.raw"});
}

TEST(CliPrep, NonFiniteVoxelsAreCountedOrRefused) {
  ScratchDir dir;
  std::vector<float> v(8 * 8 * 8, 2.0f);
  v[3] = NAN;
  v[100] = INFINITY;
  test::writeFile(dir / "v.raw", v.data(), v.size() * 4);
  const std::string in = (dir / "v.raw").string() + " --dims 8,8,8 --type f32 --brick 8 -q ";
  auto r = runVoxbrick("prep " + in + "-o " + (dir / "s").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("2 NaN/Inf values replaced"), std::string::npos) << r.output;
  expectError(runVoxbrick("prep " + in + "--nonfinite error -o " + (dir / "e").string()), {"non-finite", "(3, 0, 0)"});
  expectOnly(dir.path(), {"v.raw", "s"});
}

TEST(CliPrep, QuantiseFindsTheExactRangeOrTakesTheGivenOne) {
  ScratchDir dir;
  std::vector<float> v(20 * 12 * 9);
  for (size_t i = 0; i < v.size(); ++i) v[i] = float(-1.5 + 4.0 * std::sin(double(i) * 0.013));
  v[7] = NAN;  // replaced by the background (0) before the range is taken
  test::writeFile(dir / "v.raw", v.data(), v.size() * 4);
  float lo = 0, hi = 0;  // the background is part of the range
  for (float x : v)
    if (!std::isnan(x)) lo = std::min(lo, x), hi = std::max(hi, x);
  const std::string in = "prep " + (dir / "v.raw").string() + " --dims 20,12,9 --type f32 --brick 8 -q ";
  auto r = runVoxbrick(in + "--quantise u8 -o " + (dir / "a").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("quantised ["), std::string::npos) << r.output;
  r = runVoxbrick("info --json " + (dir / "a").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["type"], "u8");
  EXPECT_EQ(j["quantisation"]["type"], "u8");
  EXPECT_EQ(j["quantisation"]["range"], nlohmann::json({double(lo), double(hi)}));
  EXPECT_EQ(j["value_range"], nlohmann::json({0.0, 255.0}));
  EXPECT_EQ(j["nonfinite_replaced"], 1);

  r = runVoxbrick(in + "--quantise u16 --quantise-range -1,1 -o " + (dir / "b").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  j = nlohmann::json::parse(runVoxbrick("info --json " + (dir / "b").string()).output);
  EXPECT_EQ(j["type"], "u16");
  EXPECT_EQ(j["quantisation"]["range"], nlohmann::json({-1.0, 1.0}));
  EXPECT_GT(j["quantisation"]["clamped"].get<int64_t>(), 0);
  EXPECT_NE(runVoxbrick("info " + (dir / "b").string()).output.find("quantised    from [-1, 1]"), std::string::npos);

  const std::string out = "-o " + (dir / "c").string();
  expectError(runVoxbrick(in + "--quantise f32 " + out), {"--quantise", "f32", "u8 or u16"});
  expectError(runVoxbrick(in + "--quantise u8 --quantise-range 2,2 " + out),
              {"--quantise-range", "lo must be below hi"});
  expectError(runVoxbrick(in + "--quantise u8 --quantise-range 3,1 " + out), {"lo must be below hi"});
  expectError(runVoxbrick(in + "--quantise u8 --quantise-range 0,inf " + out), {"finite"});
  expectError(runVoxbrick(in + "--quantise u8 --quantise-range 0,nan " + out), {"finite"});
  expectError(runVoxbrick(in + "--quantise u8 --quantise-range 0 " + out), {"two numbers"});
  expectError(runVoxbrick(in + "--quantise-range 0,1 " + out), {"--quantise-range needs --quantise"});
  expectError(runVoxbrick(in + "--quantise u8 --nonfinite error " + out), {"non-finite", "(7, 0, 0)"});
  expectOnly(dir.path(), {"v.raw", "a", "b"});
}

TEST(CliPrep, UnwritableOutputAndFullDiskLeaveNothingBehind) {
  ScratchDir dir;
  std::vector<float> v(64 * 64 * 64);
  for (size_t i = 0; i < v.size(); ++i) v[i] = float(std::sin(double(i) * 0.37));
  test::writeFile(dir / "v.raw", v.data(), v.size() * 4);
  const std::string in = "prep " + (dir / "v.raw").string() + " --dims 64,64,64 --type f32 -q ";
  expectError(runVoxbrick(in + "-o " + (dir / "v.raw" / "store").string()), {"cannot create"});
  expectError(runVoxbrick(in + "-o " + (dir / "missing" / "store").string()), {"cannot create", "missing"});

  // A file-size limit makes writes fail the way a full disk does (EFBIG instead of ENOSPC).
  auto r = runShell("ulimit -f 256 && " + std::string(VOXBRICK_EXE) + " " + in + "-o " + (dir / "s").string());
  expectError(r, {"write", "failed"});
  expectOnly(dir.path(), {"v.raw"});
}

TEST(CliPrep, InterruptLeavesNothingBehind) {
  ScratchDir dir;
  // A 512^3 field takes seconds to convert; SIGINT once the store under construction appears (its handler is in
  // place by then, however loaded the machine) must stop it cleanly.
  auto r = runShell("(" + std::string(VOXBRICK_EXE) + " prep synthetic:blobs,n=512 -q -o " + (dir / "s").string() +
                    " & pid=$!; for i in $(seq 600); do [ -n \"$(ls -A " + dir.path().string() +
                    ")\" ] && break; sleep 0.05; done; sleep 0.2; kill -INT $pid; wait $pid)");
  expectError(r, {"interrupted"});
  expectOnly(dir.path(), {});
}

TEST(CliInfo, CorruptStoreFailsCleanly) {
  ScratchDir dir;
  auto r = runVoxbrick("prep synthetic:blobs,n=32 --brick 8 -q -o " + (dir / "s").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  std::filesystem::resize_file(dir / "s" / "bricks.bin", 10);
  expectError(runVoxbrick("info " + (dir / "s").string()), {"bricks.bin", "truncated"});
  expectError(runVoxbrick("info " + (dir / "nothing").string()), {"nothing: no such file or directory"});
  std::filesystem::create_directories(dir / "empty");
  expectError(runVoxbrick("info " + (dir / "empty").string()), {"store.json: missing", "not a complete store"});
}

}  // namespace
}  // namespace voxbrick
