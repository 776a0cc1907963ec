// `voxbrick prep` of a DICOM series and a TIFF stack as a user runs it: the real binary, then `info --json`.
#include <gtest/gtest.h>
#include <tiffio.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>

#include "support/DicomSeries.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::runVoxbrick;
using test::ScratchDir;

void expectNear(const nlohmann::json& actual, const std::vector<double>& expected, const std::string& what) {
  ASSERT_EQ(actual.size(), expected.size()) << what << ": " << actual;
  for (size_t i = 0; i < expected.size(); ++i) EXPECT_NEAR(actual[i].get<double>(), expected[i], 1e-9) << what;
}

TEST(CliDicom, PrepOfASeriesDirectoryKeepsDimsSpacingAndOrientation) {
  ScratchDir dir;
  test::DicomSeriesSpec s;
  s.dims = {12, 10, 9};
  s.spacing = {0.7, 0.9, 2.5};
  s.rowLps = {0, 1, 0};      // a sagittal series: columns run posterior
  s.columnLps = {0, 0, -1};  // rows run inferior; slices step along row x column = (-1, 0, 0): right
  s.originLps = {40, -60, 80};
  test::writeDicomSeries(dir / "series", s,
                         [](const test::Vec3& ras) { return 500 + ras[0] + 2 * ras[1] + 3 * ras[2]; });
  auto r = runVoxbrick("prep " + (dir / "series").string() + " --brick 8 -q -o " + (dir / "store").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;

  r = runVoxbrick("info --json " + (dir / "store").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["dims"], nlohmann::json({12, 10, 9}));
  expectNear(j["spacing"], {0.7, 0.9, 2.5}, "spacing");
  EXPECT_EQ(j["type"], "i16");
  ASSERT_TRUE(j.contains("orientation")) << r.output;
  const auto& o = j["orientation"];
  EXPECT_EQ(o["space"], "RAS");
  EXPECT_EQ(o["patient"], true);
  expectNear(o["axes"][0], {0, -1, 0}, "axis i");
  expectNear(o["axes"][1], {0, 0, -1}, "axis j");
  expectNear(o["axes"][2], {1, 0, 0}, "axis k");
  expectNear(o["origin"], {-40, 60, 80}, "origin");
}

TEST(CliDicom, MixedSeriesNeedSeriesAndBadInputsGiveOneLine) {
  ScratchDir dir;
  test::DicomSeriesSpec a, b;
  a.dims = {4, 4, 3};
  a.seriesUid = "1.2.3.7.1";
  a.prefix = "a";
  b.dims = {4, 4, 4};
  b.seriesUid = "1.2.3.7.2";
  b.prefix = "b";
  auto f = [](const test::Vec3& ras) { return ras[0]; };
  test::writeDicomSeries(dir / "in", a, f);
  test::writeDicomSeries(dir / "in", b, f);
  const std::string out = " -q -o " + (dir / "s").string();
  auto r = runVoxbrick("prep " + (dir / "in").string() + out);
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("--series"), std::string::npos) << r.output;
  // The series follow the error line as a table, one a line: UID, modality, description, size, slices, files.
  EXPECT_NE(r.output.find("\n  UID "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\n  1.2.3.7.1 "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\n  1.2.3.7.2 "), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 4) << r.output;

  r = runVoxbrick("prep " + (dir / "in").string() + " --series 1.2.3.7.2 --brick 8" + out);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  r = runVoxbrick("info --json " + (dir / "s").string());
  EXPECT_EQ(nlohmann::json::parse(r.output)["dims"], nlohmann::json({4, 4, 4}));

  // The files of one series given one by one (as a shell expands a glob).
  std::string files;
  for (int k = 0; k < 3; ++k) files += " " + (dir / "in" / ("a00" + std::to_string(k) + ".dcm")).string();
  r = runVoxbrick("prep" + files + " --brick 8 --force" + out);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  r = runVoxbrick("info --json " + (dir / "s").string());
  EXPECT_EQ(nlohmann::json::parse(r.output)["dims"], nlohmann::json({4, 4, 3}));
}

TEST(CliDicom, PrepOfATiffGlobWithSpacing) {
  ScratchDir dir;
  for (int z = 1; z <= 10; ++z) {
    TIFF* t = TIFFOpen((dir / ("img" + std::to_string(z) + ".tif")).c_str(), "w");
    ASSERT_NE(t, nullptr);
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, 6u);
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, 5u);
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 16);
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 1);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
    std::vector<uint16_t> row(6, uint16_t(z));
    for (uint32_t y = 0; y < 5; ++y) ASSERT_EQ(TIFFWriteScanline(t, row.data(), y, 0), 1);
    TIFFClose(t);
  }
  auto r = runVoxbrick("prep '" + (dir / "img*.tif").string() + "' --spacing 0.3,0.3,1.2 --brick 8 -q -o " +
                       (dir / "s").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  r = runVoxbrick("info --json " + (dir / "s").string());
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["dims"], nlohmann::json({6, 5, 10}));
  expectNear(j["spacing"], {0.3, 0.3, 1.2}, "spacing");
  EXPECT_EQ(j["type"], "u16");
  // A TIFF states no patient frame: the identity, patient false.
  ASSERT_TRUE(j.contains("orientation")) << r.output;
  EXPECT_EQ(j["orientation"]["patient"], false);
  EXPECT_EQ(j["orientation"]["axes"], nlohmann::json({{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}));
}

}  // namespace
}  // namespace voxbrick
