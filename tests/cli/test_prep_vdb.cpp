// The OpenVDB grid prep writes beside a store is a dataset in its own right: read back with its spacing.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <vector>

#include "cli/CliRun.h"
#include "image/Image.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::runSplit;

TEST(PrepVdb, AnisotropicGridIsReadBackWithItsSpacing) {
  test::ScratchDir dir;
  std::vector<uint8_t> v(32 * 32 * 16);
  for (size_t i = 0; i < v.size(); ++i) v[i] = uint8_t((i * 7) % 200);
  test::writeFile(dir / "v.raw", v.data(), v.size());
  const std::string store = (dir / "s").string();
  ASSERT_EQ(runSplit("prep " + (dir / "v.raw").string() +
                     " --dims 32,32,16 --type u8 --spacing 1,1.5,2.5 --brick 8 -q -o " + store)
                .exitCode,
            0);
  const std::string vdb = (dir / "s" / "vdb" / "level0-z00000.vdb").string();
  ASSERT_TRUE(std::filesystem::exists(vdb));
  const test::SplitResult info = runSplit("info --json " + vdb);
  ASSERT_EQ(info.exitCode, 0) << info.err;
  const nlohmann::json j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["dims"], nlohmann::json({32, 32, 16}));
  EXPECT_EQ(j["spacing"], nlohmann::json({1.0, 1.5, 2.5}));
  // prep of the grid, and a frame of it read live, are those of the store.
  const test::SplitResult again = runSplit("prep " + vdb + " --brick 8 -q -o " + (dir / "s2").string());
  ASSERT_EQ(again.exitCode, 0) << again.err;
  const test::SplitResult info2 = runSplit("info --json " + (dir / "s2").string());
  EXPECT_EQ(nlohmann::json::parse(info2.out)["spacing"], nlohmann::json({1.0, 1.5, 2.5}));
  const std::string common = " --size 48x48 -q -o ";
  const test::SplitResult prepped = runSplit("render " + store + common + (dir / "store.png").string());
  ASSERT_EQ(prepped.exitCode, 0) << prepped.err;
  const test::SplitResult live = runSplit("render " + vdb + " --brick 8" + common + (dir / "live.png").string());
  ASSERT_EQ(live.exitCode, 0) << live.err;
  const image::ImageError e = image::compareImages(image::toImageF(image::readPng(dir / "store.png")),
                                                   image::toImageF(image::readPng(dir / "live.png")));
  EXPECT_LE(e.maxAbs, 1.0 / 255 + 1e-6);
}

}  // namespace
}  // namespace voxbrick
