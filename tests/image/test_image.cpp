// `voxbrick compare` and the difference heat map on images whose error is known exactly; scaling an image (area means
// shrinking, bilinear growing, pixel centres aligned).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "image/Image.h"
#include "support/TestSupport.h"

namespace voxbrick::image {
namespace {

using test::ScratchDir;

/// A grey 8-bit image, every channel `value`.
Image8 grey(int width, int height, uint8_t value) {
  Image8 image{width, height, std::vector<uint8_t>(size_t(width) * size_t(height) * 4, value)};
  for (size_t i = 3; i < image.rgba.size(); i += 4) image.rgba[i] = 255;
  return image;
}

/// A pattern with detail at every scale: each channel its own mix of the pixel's coordinates.
Image8 detailed(int width, int height) {
  Image8 image{width, height, std::vector<uint8_t>(size_t(width) * size_t(height) * 4)};
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      uint8_t* p = image.rgba.data() + 4 * (size_t(y) * size_t(width) + size_t(x));
      p[0] = uint8_t((x * 37 + y * 11) % 256), p[1] = uint8_t((x * x + 3 * y) % 256);
      p[2] = uint8_t((x ^ y) * 7 % 256), p[3] = uint8_t(255 - (x + y) % 64);
    }
  return image;
}

/// The mean of the area of `image` that pixel (x, y) of a `width` x `height` shrinking of it covers, channel `c`.
double areaMean(const Image8& image, int width, int height, int x, int y, int c) {
  const double rx = double(image.width) / width, ry = double(image.height) / height;
  double sum = 0, area = 0;
  for (int sy = 0; sy < image.height; ++sy)
    for (int sx = 0; sx < image.width; ++sx) {
      const double wx = std::max(0.0, std::min((x + 1) * rx, sx + 1.0) - std::max(x * rx, double(sx)));
      const double wy = std::max(0.0, std::min((y + 1) * ry, sy + 1.0) - std::max(y * ry, double(sy)));
      sum += wx * wy * image.rgba[4 * (size_t(sy) * size_t(image.width) + size_t(sx)) + size_t(c)];
      area += wx * wy;
    }
  return sum / area;
}

TEST(ScaleImage, AShrunkPixelIsTheMeanOfTheAreaItCovers) {
  const Image8 image = detailed(32, 24);
  // 0.75 and 0.375 (no whole number of pixels to a pixel), 0.5, and each axis its own.
  for (const auto& [width, height] : {std::pair{24, 18}, std::pair{12, 9}, std::pair{16, 12}, std::pair{20, 7}}) {
    const Image8 out = scaleImage(image, width, height);
    ASSERT_EQ(out.width, width);
    ASSERT_EQ(out.height, height);
    ASSERT_EQ(out.rgba.size(), size_t(width) * size_t(height) * 4);
    double worst = 0;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        for (int c = 0; c < 4; ++c)
          worst = std::max(worst, std::abs(out.rgba[4 * (size_t(y) * size_t(width) + size_t(x)) + size_t(c)] -
                                           areaMean(image, width, height, x, y, c)));
    EXPECT_LE(worst, 0.6) << width << "x" << height << ": within the 8 bits' rounding";
  }
}

TEST(ScaleImage, AGrownImageIsBilinearBetweenPixelCentres) {
  // A ramp of 8 a pixel, 4 at the first pixel's centre, twice as wide: output pixel j's centre lies at
  // (j + 0.5) / 2 - 0.5 source pixels, where the ramp is 4 j + 2; the first and last are clamped to the ends.
  Image8 ramp{16, 1, std::vector<uint8_t>(16 * 4)};
  for (int x = 0; x < 16; ++x)
    for (int c = 0; c < 4; ++c) ramp.rgba[size_t(4 * x + c)] = uint8_t(8 * x + 4);
  const Image8 out = scaleImage(ramp, 32, 3);
  ASSERT_EQ(out.width, 32);
  for (int y = 0; y < 3; ++y)
    for (int j = 0; j < 32; ++j) {
      const double want = j == 0 ? 4 : j == 31 ? 124 : 4 * j + 2;
      EXPECT_NEAR(out.rgba[4 * (size_t(y) * 32 + size_t(j))], want, 0.5) << "pixel " << j << " of row " << y;
    }
}

TEST(ScaleImage, AFlatImageStaysFlatAtAnySize) {
  const Image8 flat = grey(37, 23, 200);
  for (const auto& [width, height] : {std::pair{11, 7}, std::pair{80, 50}, std::pair{37, 5}, std::pair{1, 1}}) {
    const Image8 out = scaleImage(flat, width, height);
    for (size_t i = 0; i < out.rgba.size(); ++i)
      ASSERT_EQ(out.rgba[i], i % 4 == 3 ? 255 : 200) << width << "x" << height << ", byte " << i;
  }
  EXPECT_EQ(scaleImage(flat, 37, 23).rgba, flat.rgba) << "its own size: the same image";
}

TEST(ScaleImage, AbsurdSizesAreRefused) {
  const Image8 image = grey(8, 8, 10);
  EXPECT_THROW(scaleImage(image, 0, 8), ImageFailure);
  EXPECT_THROW(scaleImage(image, 8, 20000), ImageFailure);
  EXPECT_THROW(scaleImage(Image8{8, 8, std::vector<uint8_t>(10)}, 4, 4), ImageFailure) << "bytes that are no image";
}

TEST(CompareHeatmap, ShowsWhereAndHowMuch) {
  ImageF a = toImageF(grey(4, 3, 51));
  ImageF b = a;
  b.pixel(2, 1)[1] += 0.5f;
  b.pixel(0, 0)[0] -= 0.125f;
  const ImageF map = differenceHeatmap(a, b, 0.5);
  EXPECT_FLOAT_EQ(map.pixel(2, 1)[0], 1.0f) << "the largest difference is white";
  EXPECT_FLOAT_EQ(map.pixel(2, 1)[2], 1.0f);
  EXPECT_FLOAT_EQ(map.pixel(3, 2)[0], 0.0f) << "no difference is black";
  EXPECT_GT(map.pixel(0, 0)[0], 0.1f) << "a quarter of the scale is visible";
  EXPECT_LT(map.pixel(0, 0)[0], 0.9f);
  EXPECT_THROW(differenceHeatmap(a, b, 0.0), ImageFailure);
  EXPECT_THROW(differenceHeatmap(a, toImageF(grey(3, 4, 51)), 1.0), ImageFailure);
}

TEST(CompareCli, PrintsTheKnownErrorAsTextAndJson) {
  ScratchDir dir;
  const int w = 8, h = 5;
  Image8 a = grey(w, h, 51);
  Image8 b = a;
  b.rgba[4 * (3 + w * 2) + 1] += 10;  // one channel of one pixel, 10/255 brighter
  writePng(dir / "a.png", a);
  writePng(dir / "b.png", b);
  const double maxAbs = 10.0 / 255;
  const double rmse = std::sqrt(maxAbs * maxAbs / (3.0 * w * h));

  auto r = test::runVoxbrick("compare " + (dir / "a.png").string() + " " + (dir / "b.png").string() + " --json" +
                             " --heatmap " + (dir / "heat.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_NEAR(j["max_abs"].get<double>(), maxAbs, 1e-6);
  EXPECT_NEAR(j["rmse"].get<double>(), rmse, 1e-7);
  EXPECT_NEAR(j["psnr"].get<double>(), 20 * std::log10(1 / rmse), 1e-3);
  EXPECT_EQ(j["width"], w);
  EXPECT_FALSE(j["identical"].get<bool>());
  const Image8 heat = readPng(dir / "heat.png");
  ASSERT_EQ(heat.width, w);
  ASSERT_EQ(heat.height, h);
  EXPECT_EQ(heat.rgba[4 * (3 + w * 2)], 255) << "the one differing pixel is white";
  EXPECT_EQ(heat.rgba[0], 0);

  r = test::runVoxbrick("compare " + (dir / "a.png").string() + " " + (dir / "b.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("psnr 48.92 dB"), std::string::npos) << r.output;

  r = test::runVoxbrick("compare " + (dir / "a.png").string() + " " + (dir / "a.png").string() + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const nlohmann::json same = nlohmann::json::parse(r.output);
  EXPECT_TRUE(same["psnr"].is_null()) << "identical images: infinite PSNR, which JSON spells null";
  EXPECT_TRUE(same["identical"].get<bool>());
  EXPECT_EQ(same["rmse"].get<double>(), 0.0);
}

TEST(CompareCli, NamesMissingFilesAndSizeMismatches) {
  ScratchDir dir;
  writePng(dir / "a.png", grey(8, 5, 0));
  writePng(dir / "c.png", grey(5, 8, 0));
  auto r = test::runVoxbrick("compare " + (dir / "a.png").string() + " " + (dir / "nosuch.png").string());
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("nosuch.png"), std::string::npos) << r.output;
  r = test::runVoxbrick("compare " + (dir / "a.png").string() + " " + (dir / "c.png").string());
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("sizes differ (8x5 vs 5x8)"), std::string::npos) << r.output;
  test::writeFile(dir / "text.png", std::string("not a png"));
  r = test::runVoxbrick("compare " + (dir / "a.png").string() + " " + (dir / "text.png").string());
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("text.png"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace voxbrick::image
