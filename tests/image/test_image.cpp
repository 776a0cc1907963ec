// `voxbrick compare` and the difference heat map on images whose error is known exactly.
#include <gtest/gtest.h>

#include <cmath>

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
