// TIFF stacks at ingest: multi-page files and globs of single-page files written by libtiff, read back as z-slices;
// every refusal names the file (and page) and the problem.
#include <gtest/gtest.h>
#include <tiffio.h>

#include <cstring>
#include <filesystem>
#include <functional>
#include <vector>

#include "InputRefusals.h"
#include "brickstore/format/Errors.h"
#include "brickstore/ingest/Sources.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::expectRefused;

using store::InputError;
using store::ValueType;
using test::ScratchDir;
using test::openAndRead;

/// One page to write: its layout and its bytes, rows top to bottom.
struct Page {
  uint32_t width = 0, height = 0;
  uint16_t bits = 8, format = SAMPLEFORMAT_UINT, samples = 1;
  std::vector<unsigned char> data;
};

/// A single-channel page of type T with value f(x, y).
template <typename T>
Page page(uint32_t width, uint32_t height, const std::function<double(uint32_t, uint32_t)>& f) {
  Page p;
  p.width = width, p.height = height;
  p.bits = uint16_t(8 * sizeof(T));
  p.format = std::is_floating_point_v<T> ? SAMPLEFORMAT_IEEEFP
             : std::is_signed_v<T>       ? SAMPLEFORMAT_INT
                                         : SAMPLEFORMAT_UINT;
  p.data.resize(size_t(width) * height * sizeof(T));
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      const T v = T(f(x, y));
      std::memcpy(p.data.data() + (size_t(y) * width + x) * sizeof(T), &v, sizeof(T));
    }
  return p;
}

/// Writes the pages into one file with libtiff, LZW-compressed in strips of two rows.
void writeTiff(const std::filesystem::path& path, const std::vector<Page>& pages) {
  TIFF* t = TIFFOpen(path.c_str(), "w");
  ASSERT_NE(t, nullptr);
  for (const Page& p : pages) {
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, p.width);
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, p.height);
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, p.bits);
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, p.samples);
    TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, p.format);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, p.samples == 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK);
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_LZW);
    TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, 2);
    if (pages.size() > 1) TIFFSetField(t, TIFFTAG_SUBFILETYPE, FILETYPE_PAGE);
    const size_t rowBytes = size_t(p.width) * p.samples * p.bits / 8;
    for (uint32_t y = 0; y < p.height; ++y) {
      std::vector<unsigned char> row(p.data.begin() + long(y * rowBytes), p.data.begin() + long((y + 1) * rowBytes));
      ASSERT_EQ(TIFFWriteScanline(t, row.data(), y, 0), 1);
    }
    ASSERT_EQ(TIFFWriteDirectory(t), 1);
  }
  TIFFClose(t);
}

double ramp(uint32_t x, uint32_t y, int z) { return 1000.0 * z + 10.0 * y + x; }

/// Three 16-bit pages of width x height holding ramp(x, y, page).
std::vector<Page> rampPages(uint32_t width, uint32_t height) {
  std::vector<Page> pages;
  for (int z = 0; z < 3; ++z)
    pages.push_back(page<uint16_t>(width, height, [z](uint32_t x, uint32_t y) { return ramp(x, y, z); }));
  return pages;
}

TEST(Tiff, MultiPageFileIsAStackOfSlices) {
  ScratchDir dir;
  writeTiff(dir / "stack.tif", rampPages(5, 4));
  auto source = store::openSource((dir / "stack.tif").string(), {});
  const store::VolumeInfo& info = source->info();
  EXPECT_EQ(info.dims, (store::Vec3i{5, 4, 3}));
  EXPECT_EQ(info.type, ValueType::U16);
  EXPECT_EQ(info.spacing, (store::Vec3d{1, 1, 1}));
  EXPECT_EQ(info.orientation, store::Orientation{});
  EXPECT_NE(info.description.find("--spacing"), std::string::npos) << info.description;
  std::vector<double> expected;
  for (int z = 0; z < 3; ++z)
    for (uint32_t y = 0; y < 4; ++y)
      for (uint32_t x = 0; x < 5; ++x) expected.push_back(ramp(x, y, z));
  EXPECT_EQ(test::readValues(*source), expected);

  store::SourceOptions options;
  options.spacing = {0.2, 0.2, 1.5};
  options.spacingGiven = true;
  EXPECT_EQ(store::openSource((dir / "stack.tif").string(), options)->info().spacing, options.spacing);
}

TEST(Tiff, SampleTypes) {
  ScratchDir dir;
  auto f = [](uint32_t x, uint32_t y) { return double(x) - 2.0 * y; };
  writeTiff(dir / "u8.tif", {page<uint8_t>(3, 2, [](uint32_t x, uint32_t y) { return x + 7.0 * y; })});
  writeTiff(dir / "i16.tif", {page<int16_t>(3, 2, f), page<int16_t>(3, 2, f)});
  writeTiff(dir / "f32.tif", {page<float>(3, 2, [](uint32_t x, uint32_t y) { return x * 0.25 - y * 1.5; })});
  auto u8 = store::openSource((dir / "u8.tif").string(), {});
  EXPECT_EQ(u8->info().type, ValueType::U8);
  EXPECT_EQ(test::readValues(*u8), (std::vector<double>{0, 1, 2, 7, 8, 9}));
  auto i16 = store::openSource((dir / "i16.tif").string(), {});
  EXPECT_EQ(i16->info().type, ValueType::I16);
  EXPECT_EQ(test::readValues(*i16), (std::vector<double>{0, 1, 2, -2, -1, 0, 0, 1, 2, -2, -1, 0}));
  auto f32 = store::openSource((dir / "f32.tif").string(), {});
  EXPECT_EQ(f32->info().type, ValueType::F32);
  EXPECT_EQ(test::readValues(*f32), (std::vector<double>{0, 0.25, 0.5, -1.5, -1.25, -1}));
}

TEST(Tiff, SinglePageFilesStackInNaturalOrder) {
  ScratchDir dir;
  std::vector<std::string> files;
  for (int z = 1; z <= 12; ++z) {
    files.push_back((dir / ("slice" + std::to_string(z) + ".tif")).string());
    writeTiff(files.back(), {page<uint8_t>(2, 2, [z](uint32_t x, uint32_t) { return 10.0 * z + x; })});
  }
  std::vector<double> expected;
  for (int z = 1; z <= 12; ++z)
    for (int v : {0, 1, 0, 1}) expected.push_back(10.0 * z + v);
  // A glob, the directory, and the files in lexical (shell) order: slice10 before slice2 there, not in z.
  std::vector<std::string> lexical = files;
  std::sort(lexical.begin(), lexical.end());
  for (auto open : std::vector<std::function<std::unique_ptr<store::VolumeSource>()>>{
           [&] { return store::openSource((dir / "slice*.tif").string(), {}); },
           [&] { return store::openSource(dir.path().string(), {}); },
           [&] { return store::openSource(lexical, {}); }}) {
    auto source = open();
    EXPECT_EQ(source->info().dims, (store::Vec3i{2, 2, 12}));
    EXPECT_EQ(test::readValues(*source), expected);
  }
}

TEST(Tiff, RefusalsNameTheFileAndProblem) {
  ScratchDir dir;
  auto one = [](uint32_t, uint32_t) { return 1.0; };
  Page rgb = page<uint8_t>(2, 2, one);
  rgb.samples = 3;
  rgb.data.resize(12, 9);
  writeTiff(dir / "rgb.tif", {rgb});
  expectRefused(openAndRead((dir / "rgb.tif").string()), {"rgb.tif", "colour", "3 samples"});

  writeTiff(dir / "u32.tif", {page<uint32_t>(2, 2, one)});
  expectRefused(openAndRead((dir / "u32.tif").string()), {"u32.tif", "32-bit unsigned integer", "not supported"});

  writeTiff(dir / "sizes.tif", {page<uint8_t>(2, 2, one), page<uint8_t>(3, 2, one)});
  expectRefused(openAndRead((dir / "sizes.tif").string()), {"sizes.tif page 2", "3x2", "differs", "2x2"});

  writeTiff(dir / "types.tif", {page<uint8_t>(2, 2, one), page<uint16_t>(2, 2, one)});
  expectRefused(openAndRead((dir / "types.tif").string()), {"types.tif page 2", "u16", "u8"});

  ScratchDir files;
  writeTiff(files / "a1.tif", {page<uint8_t>(2, 2, one)});
  writeTiff(files / "a2.tif", {page<uint8_t>(2, 3, one)});
  expectRefused(openAndRead(files.path().string()), {"a2.tif", "2x3", "a1.tif"});
  writeTiff(files / "a2.tif", {page<uint8_t>(2, 2, one), page<uint8_t>(2, 2, one)});
  expectRefused(openAndRead((files / "a*.tif").string()), {"a2.tif", "more than one page"});

  test::writeFile(dir / "junk.tif", std::string(64, 'j'));
  expectRefused(openAndRead((dir / "junk.tif").string()), {"junk.tif", "not a readable TIFF"});
  expectRefused(openAndRead((dir / "none*.tif").string()), {"none*.tif", "no file matches"});
  ScratchDir empty;
  test::writeFile(empty / "notes.txt", std::string("x"));
  expectRefused(openAndRead(empty.path().string()), {empty.path().string(), "without DICOM or TIFF"});
}

TEST(Tiff, TruncatedFilesAreInputErrorsNotCrashes) {
  ScratchDir dir;
  writeTiff(dir / "full.tif", rampPages(7, 5));
  const std::vector<char> bytes = test::readFile(dir / "full.tif");
  const std::string cutFile = (dir / "cut.tif").string();
  for (size_t cut = 0; cut < bytes.size(); ++cut) {
    test::writeFile(cutFile, bytes.data(), cut);
    SCOPED_TRACE("cut at " + std::to_string(cut) + " of " + std::to_string(bytes.size()));
    expectRefused(openAndRead(cutFile), {"cut.tif"});
  }
}

}  // namespace
}  // namespace voxbrick
