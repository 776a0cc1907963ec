// `voxbrick orbit`: a turntable of distinct frames from one process, its first frame the `render` of the same camera.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "cli/CliRun.h"
#include "image/Image.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::runSplit;

TEST(Orbit, WritesDistinctFramesAndTheFirstIsRendersFrame) {
  test::ScratchDir dir;
  const std::string store = test::preppedStore("synthetic:blobs,n=64", "--brick 16");
  const std::string scene = " --size 48x48 --tf hot";
  const test::SplitResult r =
      runSplit("orbit -q " + store + scene + " --orbit 10,15,2.5 --elevation 25 --frames 4 -o " +
               (dir / "frames" / "f%03d.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(test::lineCount(r.out), 1) << r.out;
  std::vector<image::ImageF> frames;
  for (const std::string name : {"f000.png", "f001.png", "f002.png", "f003.png"})
    frames.push_back(image::toImageF(image::readPng(dir / "frames" / name)));
  EXPECT_FALSE(std::filesystem::exists(dir / "frames" / "f004.png"));
  for (size_t i = 0; i < frames.size(); ++i)
    for (size_t j = i + 1; j < frames.size(); ++j)
      EXPECT_GT(image::compareImages(frames[i], frames[j]).maxAbs, 0.05) << "frames " << i << " and " << j;
  const test::SplitResult single =
      runSplit("render -q " + store + scene + " --orbit 10,25,2.5 -o " + (dir / "render.png").string());
  ASSERT_EQ(single.exitCode, 0) << single.err;
  EXPECT_EQ(image::compareImages(frames[0], image::toImageF(image::readPng(dir / "render.png"))).maxAbs, 0.0);
  const test::SplitResult turned =
      runSplit("render -q " + store + scene + " --orbit 100,25,2.5 -o " + (dir / "turned.png").string());
  ASSERT_EQ(turned.exitCode, 0) << turned.err;
  EXPECT_EQ(image::compareImages(frames[1], image::toImageF(image::readPng(dir / "turned.png"))).maxAbs, 0.0);
}

TEST(Orbit, PatternsWithoutOneFrameNumberAreRefused) {
  test::ScratchDir dir;
  const std::string store = test::preppedStore("synthetic:blobs,n=64", "--brick 16");
  for (const std::string pattern : {"f.png", "f%d%d.png", "f%s.png", "f%03d.gif"}) {
    const test::SplitResult r = runSplit("orbit -q " + store + " --frames 2 -o " + (dir / pattern).string());
    EXPECT_EQ(r.exitCode, 1) << pattern;
    EXPECT_EQ(test::lineCount(r.err), 1) << r.err;
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace voxbrick
