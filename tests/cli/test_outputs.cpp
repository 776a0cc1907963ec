// Files the commands write: the format follows the extension (PNG, JPEG), writes are atomic, and a transparent
// background gives alpha. Images are read back and their pixels checked.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/CliRun.h"
#include "image/Image.h"
#include "image/ImageFile.h"
#include "server/ServerProcess.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

namespace fs = std::filesystem;
using test::lineCount;
using test::runSplit;

std::string outputsBlobs() { return test::preppedStore("synthetic:blobs,n=64", "--brick 16"); }

/// The spread of a channel over the image: a frame with a volume in it is far from uniform.
int channelSpread(const image::Image8& img, int channel) {
  uint8_t lo = 255, hi = 0;
  for (size_t i = size_t(channel); i < img.rgba.size(); i += 4)
    lo = std::min(lo, img.rgba[i]), hi = std::max(hi, img.rgba[i]);
  return int(hi) - int(lo);
}

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(ImageOutput, JpegFollowsTheExtensionAndKeepsTheContent) {
  test::ScratchDir dir;
  const std::string common = "render -q " + outputsBlobs() + " --size 96x96 --tf hot -o ";
  ASSERT_EQ(runSplit(common + (dir / "f.png").string()).exitCode, 0);
  ASSERT_EQ(runSplit(common + (dir / "f.jpg").string() + " --jpeg-quality 95").exitCode, 0);
  ASSERT_EQ(runSplit(common + (dir / "f.JPEG").string() + " --jpeg-quality 10").exitCode, 0);
  const std::vector<char> jpgBytes = test::readFile(dir / "f.jpg");
  ASSERT_GE(jpgBytes.size(), 3u);
  EXPECT_EQ(uint8_t(jpgBytes[0]), 0xFF);
  EXPECT_EQ(uint8_t(jpgBytes[1]), 0xD8);
  const image::Image8 png = image::readPng(dir / "f.png");
  const image::Image8 jpg = image::readImage(dir / "f.jpg");
  const image::Image8 rough = image::readImage(dir / "f.JPEG");
  ASSERT_EQ(jpg.width, 96);
  ASSERT_EQ(jpg.height, 96);
  EXPECT_GT(channelSpread(png, 0), 100);  // the frame shows the volume, so the comparison below means something
  const double fine = image::compareImages(image::toImageF(png), image::toImageF(jpg)).psnr;
  const double coarse = image::compareImages(image::toImageF(png), image::toImageF(rough)).psnr;
  EXPECT_GT(fine, 32) << "quality 95 against the PNG";
  EXPECT_GT(coarse, 20) << "quality 10 against the PNG";
  EXPECT_GT(fine, coarse + 3) << "--jpeg-quality is used";
  EXPECT_LT(fs::file_size(dir / "f.JPEG"), fs::file_size(dir / "f.jpg"));
}

TEST(ImageOutput, OtherExtensionsAreRefusedBeforeRendering) {
  test::ScratchDir dir;
  for (const std::string name : {"f.gif", "f.tiff", "f"}) {
    const test::SplitResult r = runSplit("render -q " + outputsBlobs() + " --size 32x32 -o " + (dir / name).string());
    EXPECT_EQ(r.exitCode, 1) << name;
    EXPECT_EQ(lineCount(r.err), 1) << r.err;
    EXPECT_NE(r.err.find("extension '" + fs::path(name).extension().string() + "'"), std::string::npos) << r.err;
  }
  // request refuses it before it connects (nothing listens on port 1).
  const test::SplitResult r = runSplit("request 127.0.0.1:1 --dataset d -o " + (dir / "f.bmp").string());
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find(".bmp"), std::string::npos) << r.err;
  EXPECT_TRUE(entries(dir.path()).empty());
}

TEST(ImageOutput, JpegRoundTripInMemory) {
  image::Image8 img{16, 8, std::vector<uint8_t>(16 * 8 * 4)};
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) {
      uint8_t* p = &img.rgba[size_t(y * 16 + x) * 4];
      p[0] = uint8_t(x * 16), p[1] = uint8_t(y * 32), p[2] = 128, p[3] = 255;
    }
  const image::Image8 back = image::decodeJpeg(image::encodeJpeg(img, 100), "memory");
  ASSERT_EQ(back.width, 16);
  ASSERT_EQ(back.height, 8);
  EXPECT_GT(image::compareImages(image::toImageF(img), image::toImageF(back)).psnr, 35);
  EXPECT_THROW(image::encodeJpeg(img, 0), image::ImageFailure);
  const std::vector<uint8_t> junk = {0xFF, 0xD8, 0xFF, 0x00, 0x12};
  EXPECT_THROW(image::decodeJpeg(junk, "junk"), image::ImageFailure);
}

TEST(AtomicOutput, AFileSizeLimitLeavesTheOldFileAndNoPartialOne) {
  test::ScratchDir dir;
  for (const std::string name : {"f.png", "f.jpg"}) {
    const fs::path out = dir / name;
    test::writeFile(out, std::string("the old frame"));
    // 2 blocks of 512 bytes (dash's ulimit unit): far less than the frame.
    const test::SplitResult r =
        runSplit("render -q " + outputsBlobs() + " --size 256x256 --tf hot -o " + out.string(), 120, "ulimit -f 2;");
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_EQ(lineCount(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(out.string()), std::string::npos) << r.err;
    const std::vector<char> kept = test::readFile(out);
    EXPECT_EQ(std::string(kept.begin(), kept.end()), "the old frame");
    EXPECT_EQ(entries(dir.path()), std::vector<std::string>{name});
    fs::remove(out);
  }
  // Without a file there before, none is left behind either.
  const test::SplitResult r =
      runSplit("render -q " + outputsBlobs() + " --size 256x256 -o " + (dir / "new.png").string(), 120, "ulimit -f 2;");
  EXPECT_EQ(r.exitCode, 1) << r.err;
  EXPECT_TRUE(entries(dir.path()).empty());
}

TEST(AtomicOutput, StatsAndUnwritableDirectoriesNameTheFile) {
  test::ScratchDir dir;
  const std::string missing = (dir / "no-such-dir" / "f.png").string();
  const test::SplitResult r = runSplit("render -q " + outputsBlobs() + " --size 32x32 -o " + missing);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find(missing), std::string::npos) << r.err;
  // The statistics file is written the same way: under a limit the frame is small enough, the JSON not.
  test::writeFile(dir / "stats.json", std::string("{}"));
  const test::SplitResult s = runSplit("render -q " + outputsBlobs() + " --size 8x8 -o " + (dir / "f.png").string() +
                                           " --stats " + (dir / "stats.json").string(),
                                       120, "ulimit -f 1;");
  EXPECT_EQ(s.exitCode, 1) << s.err;
  EXPECT_NE(s.err.find("stats.json"), std::string::npos) << s.err;
  const std::vector<char> kept = test::readFile(dir / "stats.json");
  EXPECT_EQ(std::string(kept.begin(), kept.end()), "{}");
}

/// A transfer function with little opacity everywhere: rays through the volume stay translucent.
std::string translucentTf(const test::ScratchDir& dir) {
  const fs::path path = dir / "faint.json";
  test::writeFile(path,
                  std::string(R"({"points": [[0, 1, 0.5, 0.2, 0], [0.2, 1, 0.5, 0.2, 0.002], [1, 1, 1, 1, 0.004]]})"));
  return path.string();
}

/// Alpha at the corner (no volume there) and at the centre (through the volume).
void expectTransparency(const image::Image8& img, const std::string& what) {
  const uint8_t* corner = &img.rgba[0];
  const uint8_t* centre = &img.rgba[(size_t(img.height / 2) * size_t(img.width) + size_t(img.width / 2)) * 4];
  EXPECT_EQ(corner[3], 0) << what;
  EXPECT_GT(centre[3], 0) << what;
  EXPECT_LT(centre[3], 255) << what;
  EXPECT_GT(centre[0], centre[3]) << what << ": colour is straight, not premultiplied";
}

TEST(Transparency, BackgroundNoneGivesAlphaFromOpacity) {
  test::ScratchDir dir;
  const std::string tf = translucentTf(dir);
  const std::string common = "render -q " + outputsBlobs() + " --size 48x48 --tf " + tf + " --background none -o ";
  ASSERT_EQ(runSplit(common + (dir / "gpu.png").string()).exitCode, 0);
  ASSERT_EQ(runSplit(common + (dir / "ref.png").string() + " --backend reference --reference-step 0.5").exitCode, 0);
  const image::Image8 gpu = image::readPng(dir / "gpu.png"), ref = image::readPng(dir / "ref.png");
  expectTransparency(gpu, "gpu");
  expectTransparency(ref, "reference");
  int worst = 0;
  for (size_t i = 3; i < gpu.rgba.size(); i += 4)
    worst = std::max(worst, std::abs(int(gpu.rgba[i]) - int(ref.rgba[i])));
  EXPECT_LE(worst, 3) << "the GPU's alpha is the reference's";
  // Opaque by default; and JPEG, which has no alpha, is refused.
  ASSERT_EQ(
      runSplit("render -q " + outputsBlobs() + " --size 48x48 --tf " + tf + " -o " + (dir / "opaque.png").string())
          .exitCode,
      0);
  const image::Image8 opaque = image::readPng(dir / "opaque.png");
  EXPECT_EQ(channelSpread(opaque, 3), 0);
  EXPECT_EQ(opaque.rgba[3], 255);
  const test::SplitResult jpg = runSplit(common + (dir / "t.jpg").string());
  EXPECT_EQ(jpg.exitCode, 1);
  EXPECT_NE(jpg.err.find("alpha"), std::string::npos) << jpg.err;
}

TEST(Transparency, TheServerSendsAlphaInEveryEncoding) {
  test::ScratchDir dir;
  fs::create_directories(dir / "datasets");
  ASSERT_EQ(
      runSplit("prep synthetic:blobs,n=64 --brick 16 --no-vdb -q -o " + (dir / "datasets" / "blobs").string()).exitCode,
      0);
  test::ServerProcess server("--datasets " + (dir / "datasets").string(), dir.path());
  const std::string tf = translucentTf(dir);
  for (const std::string encoding : {"png", "raw", "zstd"}) {
    const fs::path out = dir / (encoding + ".png");
    const test::SplitResult r = runSplit("request 127.0.0.1:" + std::to_string(server.port()) +
                                         " --dataset blobs --size 48x48 --background none --tf " + tf + " --encoding " +
                                         encoding + " -o " + out.string());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    expectTransparency(image::readPng(out), "served as " + encoding);
  }
}

TEST(RenderSummary, SaysWhenTheFrameWasCoarsenedToFitTheAtlas) {
  test::ScratchDir dir;
  // 256³ f32 in 32³ bricks: the levels this view wants take about 19 MiB, more than a 16 MiB atlas holds.
  const std::string store = test::preppedStore("synthetic:blobs,n=256", "");
  const std::string common = "render " + store + " --size 256x256 -o " + (dir / "f.png").string();
  const test::SplitResult small = runSplit(common + " --gpu-budget 16");
  ASSERT_EQ(small.exitCode, 0) << small.err;
  EXPECT_NE(small.out.find("the frame was coarsened to fit"), std::string::npos) << small.out;
  EXPECT_NE(small.out.find("the atlas holds 15.9 MiB"), std::string::npos) << small.out;
  const test::SplitResult roomy = runSplit(common);
  ASSERT_EQ(roomy.exitCode, 0) << roomy.err;
  EXPECT_EQ(roomy.out.find("coarsened to fit"), std::string::npos) << roomy.out;
}

}  // namespace
}  // namespace voxbrick
