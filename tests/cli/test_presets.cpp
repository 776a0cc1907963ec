// Transfer-function presets as a user meets them: built into the binary (a copy moved away from the source tree,
// an installed one), overridden by a config directory, listed by `voxbrick presets`, and the default's empty space.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/CliRun.h"
#include "image/Image.h"
#include "image/ImageFile.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

namespace fs = std::filesystem;
using test::runExe;
using test::runSplit;

const std::vector<std::string> kBuiltIn = {"ct-bone", "grayscale", "hot", "mri", "sparse"};

std::string presetsBlobs() { return test::preppedStore("synthetic:blobs,n=64", "--brick 16"); }

/// A copy of the binary in `dir`/bin, far from the source tree's config/.
std::string movedBinary(const test::ScratchDir& dir) {
  fs::create_directories(dir / "bin");
  const fs::path exe = dir / "bin" / "voxbrick";
  fs::copy_file(VOXBRICK_EXE, exe);
  return exe.string();
}

/// Runs with no configuration to be found: VOXBRICK_CONFIG_DIR names a missing directory, cwd is `dir`.
std::string nowhere(const test::ScratchDir& dir) {
  return "cd " + dir.path().string() + " && VOXBRICK_CONFIG_DIR=" + (dir / "nowhere").string();
}

/// A config directory holding tf/mri.json (red and fairly opaque: unlike the built-in mri) and tf/extra.json.
fs::path overridingConfig(const test::ScratchDir& dir) {
  const fs::path config = dir / "config";
  fs::create_directories(config / "tf");
  test::writeFile(config / "tf" / "mri.json", std::string(R"({"points": [[0, 1, 0, 0, 0], [1, 1, 0, 0, 0.5]]})"));
  test::writeFile(config / "tf" / "extra.json",
                  std::string(R"({"points": [[0, 0, 0, 1, 0.1]], "reference_length": 2.5})"));
  return config;
}

/// The largest difference of any channel between two frames of the same size.
int maxDifference(const image::Image8& a, const image::Image8& b) {
  int most = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) most = std::max(most, std::abs(int(a.rgba[i]) - int(b.rgba[i])));
  return most;
}

TEST(Presets, AMovedBinaryRendersABuiltInPresetAndAConfigFileOverridesIt) {
  test::ScratchDir dir;
  const std::string exe = movedBinary(dir);
  const std::string frame = "render -q " + presetsBlobs() + " --size 48x48 --tf mri -o ";
  const test::SplitResult builtIn = runExe(exe, frame + (dir / "built-in.png").string(), 120, nowhere(dir));
  ASSERT_EQ(builtIn.exitCode, 0) << builtIn.err;
  const fs::path config = overridingConfig(dir);
  const test::SplitResult file =
      runExe(exe, frame + (dir / "file.png").string(), 120, "VOXBRICK_CONFIG_DIR=" + config.string());
  ASSERT_EQ(file.exitCode, 0) << file.err;
  const image::Image8 a = image::readPng(dir / "built-in.png"), b = image::readPng(dir / "file.png");
  ASSERT_EQ(a.rgba.size(), b.rgba.size());
  EXPECT_GT(maxDifference(a, b), 50) << "the file mri.json replaces the built-in mri";
  // A name neither built in nor in the directory is refused, naming both places.
  const test::SplitResult unknown =
      runExe(exe, "render -q " + presetsBlobs() + " --tf nosuch -o " + (dir / "x.png").string(), 120, nowhere(dir));
  EXPECT_EQ(unknown.exitCode, 1);
  EXPECT_NE(unknown.err.find("no preset 'nosuch' built in or in"), std::string::npos) << unknown.err;
  EXPECT_NE(unknown.err.find("mri"), std::string::npos) << unknown.err;
}

TEST(Presets, ListsTheBuiltInPresetsAsTextWithoutColourOffATerminal) {
  test::ScratchDir dir;
  const test::SplitResult r = runSplit("presets", 60, nowhere(dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(test::lineCount(r.out), int(kBuiltIn.size())) << r.out;
  for (const std::string& name : kBuiltIn) EXPECT_NE(r.out.find(name + " "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("built in"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << "stdout is a file: no ANSI colour";
  const test::SplitResult noColour = runSplit("presets --no-color", 60, nowhere(dir));
  EXPECT_EQ(noColour.out, r.out);
}

TEST(Presets, JsonParsesAndShowsAnOverrideAsComingFromItsFile) {
  test::ScratchDir dir;
  const fs::path config = overridingConfig(dir);
  const test::SplitResult r = runSplit("presets --json", 60, "VOXBRICK_CONFIG_DIR=" + config.string());
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json list = nlohmann::json::parse(r.out);
  ASSERT_EQ(list.size(), kBuiltIn.size() + 1) << r.out;
  std::map<std::string, nlohmann::json> byName;
  for (const nlohmann::json& p : list) byName[p.at("name").get<std::string>()] = p;
  EXPECT_FALSE(byName.at("mri").at("built_in").get<bool>());
  EXPECT_EQ(byName.at("mri").at("file"), (config / "tf" / "mri.json").string());
  EXPECT_EQ(byName.at("mri").at("points").size(), 2u);
  EXPECT_TRUE(byName.at("hot").at("built_in").get<bool>());
  EXPECT_TRUE(byName.at("hot").at("file").is_null());
  EXPECT_TRUE(byName.at("hot").at("reference_length").is_null());
  EXPECT_EQ(byName.at("extra").at("reference_length").get<double>(), 2.5);
  // The text listing says the same.
  const test::SplitResult text = runSplit("presets", 60, "VOXBRICK_CONFIG_DIR=" + config.string());
  ASSERT_EQ(text.exitCode, 0) << text.err;
  EXPECT_NE(text.out.find((config / "tf" / "mri.json").string()), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("L_ref 2.5"), std::string::npos) << text.out;
}

TEST(Presets, AnInstalledBinaryFindsItsShareDirectory) {
  test::ScratchDir dir;
  const fs::path prefix = dir / "prefix";
  const test::CommandResult install = test::runShell(std::string(VOXBRICK_CMAKE) + " --install " + VOXBRICK_BUILD_DIR +
                                                     " --prefix " + prefix.string() + " 2>&1");
  ASSERT_EQ(install.exitCode, 0) << install.output;
  const fs::path share = prefix / "share" / "voxbrick";
  for (const fs::path& p : {share / "server.toml", share / "tf" / "mri.json", share / "scenes" / "orbit-default.json",
                            share / "examples" / "python" / "voxbrick_client.py",
                            share / "python" / "voxbrick" / "__init__.py", share / "python" / "voxbrick" / "session.py"})
    EXPECT_TRUE(fs::is_regular_file(p)) << p;
  const std::string exe = (prefix / "bin" / "voxbrick").string();
  fs::create_directories(dir / "elsewhere");
  const std::string unset = "cd " + (dir / "elsewhere").string() + " && unset VOXBRICK_CONFIG_DIR &&";
  // The installed command-line client finds the installed package beside it, from any directory.
  const test::CommandResult hello =
      test::runShell(unset + " unset PYTHONPATH && python3 " +
                     (share / "examples" / "python" / "voxbrick_client.py").string() + " --encode-hello hello.bin 2>&1");
  EXPECT_EQ(hello.exitCode, 0) << hello.output;
  EXPECT_TRUE(fs::is_regular_file(dir / "elsewhere" / "hello.bin"));
  const test::SplitResult list = runExe(exe, "presets", 60, unset);
  ASSERT_EQ(list.exitCode, 0) << list.err;
  EXPECT_NE(list.out.find((share / "tf" / "mri.json").string()), std::string::npos) << list.out;
  const test::SplitResult frame =
      runExe(exe, "render -q " + presetsBlobs() + " --size 32x32 --tf hot -o " + (dir / "f.png").string(), 120, unset);
  EXPECT_EQ(frame.exitCode, 0) << frame.err;
  EXPECT_TRUE(fs::is_regular_file(dir / "f.png"));
  // Its modules, in lib/voxbrick: the installed ones are those it loads (the loader's trace names each file it opens).
  const fs::path modules = prefix / "lib" / "voxbrick";
  for (const char* module : {"libvoxbrick_openvdb.so", "libvoxbrick_gdcm.so"})
    EXPECT_TRUE(fs::is_regular_file(modules / module)) << modules / module;
  const test::SplitResult grid = runExe(exe, "prep synthetic:sparse,n=32 --brick 16 -q -o " + (dir / "g").string(), 120,
                                        unset + " export LD_DEBUG=libs;");
  EXPECT_EQ(grid.exitCode, 0) << grid.err.substr(0, 2000);
  EXPECT_NE(grid.err.find((modules / "libvoxbrick_openvdb.so").string()), std::string::npos)
      << "the installed module was not the one loaded";
}

TEST(Presets, TheDefaultTransferFunctionSkipsEmptySpace) {
  // Blobs are Gaussian bumps: their background is small but nowhere exactly 0, so a ramp transparent only at 0
  // draws every brick. The default's transparent band at the bottom of the window makes the corners empty.
  test::ScratchDir dir;
  // Level 0, so that every brick is either drawn or skipped (coarser levels would stand in for the corners).
  const test::SplitResult r = runSplit("render -q " + presetsBlobs() + " --size 48x48 --lod 0 -o " +
                                       (dir / "f.png").string() + " --stats " + (dir / "stats.json").string());
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const std::vector<char> bytes = test::readFile(dir / "stats.json");
  const nlohmann::json stats = nlohmann::json::parse(std::string(bytes.begin(), bytes.end()));
  EXPECT_GT(stats.at("bricks_skipped_empty").get<int>(), 0) << stats.dump();
  EXPECT_GT(stats.at("bricks_drawn").get<int>(), 0) << stats.dump();
  EXPECT_EQ(stats.at("bricks_drawn").get<int>() + stats.at("bricks_skipped_empty").get<int>(), 64) << stats.dump();
}

}  // namespace
}  // namespace voxbrick
