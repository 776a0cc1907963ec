// DICOM series at ingest: real files written by GDCM in shuffled order, read back in position order with the right
// voxels, spacing, type and orientation; every refusal names the file and the problem.
#include <gtest/gtest.h>

#include <gdcmReader.h>
#include <gdcmWriter.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <vector>

#include "InputRefusals.h"
#include "brickstore/format/Errors.h"
#include "brickstore/ingest/Sources.h"
#include "support/DicomSeries.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::expectRefused;

using store::InputError;
using store::ValueType;
using store::VolumeSource;
using test::DicomSeriesSpec;
using test::ScratchDir;
using test::Vec3;
using test::openAndRead;

/// A smooth phantom of the world position (RAS, mm), distinct at every voxel of the small volumes used here.
double phantom(const Vec3& ras) { return 100 + 3 * ras[0] + 5 * ras[1] + 7 * ras[2]; }

/// The voxel values the reader must deliver: the written stored values, rescaled.
std::vector<double> expectedVolume(const DicomSeriesSpec& s, const std::function<double(const Vec3&)>& f) {
  std::vector<double> out;
  for (int k = 0; k < s.dims[2]; ++k)
    for (int j = 0; j < s.dims[1]; ++j)
      for (int i = 0; i < s.dims[0]; ++i)
        out.push_back(std::round((f(test::dicomVoxelRas(s, i, j, k)) - s.intercept) / s.slope) * s.slope + s.intercept);
  return out;
}

/// Checks dims, spacing, orientation (every voxel's centre where the writer put it) and every voxel.
void expectSeries(VolumeSource& source, const DicomSeriesSpec& s, const std::function<double(const Vec3&)>& f) {
  const store::VolumeInfo& info = source.info();
  ASSERT_EQ(info.dims, (store::Vec3i{s.dims[0], s.dims[1], s.dims[2]}));
  EXPECT_NEAR(info.spacing.x, s.spacing[0], 1e-9);
  EXPECT_NEAR(info.spacing.y, s.spacing[1], 1e-9);
  EXPECT_NEAR(info.spacing.z, s.spacing[2], 1e-6);
  EXPECT_TRUE(info.orientation.patient);
  for (int k : {0, s.dims[2] - 1})
    for (int j : {0, s.dims[1] - 1})
      for (int i : {0, s.dims[0] - 1}) {
        const Vec3 want = test::dicomVoxelRas(s, i, j, k);
        const auto& o = info.orientation;
        for (size_t a = 0; a < 3; ++a) {
          const double got = o.origin[a] + i * info.spacing.x * o.axes[0][a] + j * info.spacing.y * o.axes[1][a] +
                             k * info.spacing.z * o.axes[2][a];
          EXPECT_NEAR(got, want[a], 1e-5) << "voxel " << i << "," << j << "," << k << " axis " << a;
        }
      }
  EXPECT_EQ(test::readValues(source, 1), expectedVolume(s, f));
}

std::vector<std::string> strings(const std::vector<std::filesystem::path>& paths) {
  std::vector<std::string> out;
  for (const auto& p : paths) out.push_back(p.string());
  return out;
}

/// Rewrites one file with a tag changed (or removed, when `value` is empty) through GDCM.
void editTag(const std::filesystem::path& file, uint16_t group, uint16_t element, gdcm::VR vr, std::string value) {
  gdcm::Reader reader;
  reader.SetFileName(file.c_str());
  ASSERT_TRUE(reader.Read());
  gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  if (value.empty()) {
    ds.Remove(gdcm::Tag(group, element));
  } else {
    if (value.size() % 2) value += ' ';
    gdcm::DataElement de(gdcm::Tag(group, element));
    de.SetVR(vr);
    de.SetByteValue(value.data(), uint32_t(value.size()));
    ds.Replace(de);
  }
  gdcm::Writer writer;
  writer.SetFileName(file.c_str());
  writer.SetFile(reader.GetFile());
  ASSERT_TRUE(writer.Write());
}

void editUs(const std::filesystem::path& file, uint16_t group, uint16_t element, uint16_t value) {
  editTag(file, group, element, gdcm::VR::US, std::string(reinterpret_cast<const char*>(&value), 2));
}

TEST(Dicom, ShuffledAxialSeriesReadsInPositionOrder) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {6, 5, 7};
  s.spacing = {0.5, 0.75, 2.0};
  s.originLps = {-10, 20, 30};
  const auto files = test::writeDicomSeries(dir / "ct", s, phantom);

  // A directory, one file of it (its series), and the files in the order they were written.
  for (const std::string& input : {(dir / "ct").string(), files[3].string()}) {
    auto source = store::openSource(input, {});
    EXPECT_EQ(source->info().type, ValueType::I16) << input;
    const auto& o = source->info().orientation;
    EXPECT_EQ(o.axes, (std::array<store::Orientation::Vec, 3>{{{-1, 0, 0}, {0, -1, 0}, {0, 0, 1}}}));
    EXPECT_EQ(o.origin, (store::Orientation::Vec{10, -20, 30}));
    expectSeries(*source, s, phantom);
  }
  std::vector<std::string> shuffled = strings(files);
  std::swap(shuffled[0], shuffled[5]);
  std::swap(shuffled[2], shuffled[3]);
  auto source = store::openSource(shuffled, {});
  expectSeries(*source, s, phantom);
  // Read in batches, the same voxels.
  auto again = store::openSource((dir / "ct").string(), {});
  EXPECT_EQ(test::readValues(*again, 3), expectedVolume(s, phantom));
}

TEST(Dicom, ObliqueOrientationGivesRasAxesAndOrigin) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {5, 4, 6};
  s.spacing = {0.8, 1.1, 1.7};
  s.rowLps = {0.8, 0.6, 0};
  s.columnLps = {-0.36, 0.48, 0.8};
  s.originLps = {12.5, -7.25, 40};
  test::writeDicomSeries(dir.path(), s, phantom);
  auto source = store::openSource(dir.path().string(), {});
  const auto& o = source->info().orientation;
  // RAS: x and y of the LPS directions negated; the slice axis is row x column = (0.48, -0.64, 0.6) in LPS.
  const std::array<Vec3, 3> axes{{{-0.8, -0.6, 0}, {0.36, -0.48, 0.8}, {-0.48, 0.64, 0.6}}};
  for (size_t a = 0; a < 3; ++a)
    for (size_t c = 0; c < 3; ++c) EXPECT_NEAR(o.axes[a][c], axes[a][c], 1e-9) << a << "," << c;
  EXPECT_NEAR(o.origin[0], -12.5, 1e-9);
  EXPECT_NEAR(o.origin[1], 7.25, 1e-9);
  EXPECT_NEAR(o.origin[2], 40, 1e-9);
  expectSeries(*source, s, phantom);
}

TEST(Dicom, FlippedCoronalOrientation) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {4, 6, 5};
  s.spacing = {1.0, 1.5, 2.5};
  s.rowLps = {-1, 0, 0};     // columns run towards the patient's right
  s.columnLps = {0, 0, -1};  // rows run towards the feet; slices step along row x column = (0, -1, 0): anterior
  s.originLps = {3, -4, 5};
  s.shuffleSeed = 7;
  test::writeDicomSeries(dir.path(), s, phantom);
  auto source = store::openSource(dir.path().string(), {});
  const auto& o = source->info().orientation;
  EXPECT_EQ(o.axes, (std::array<store::Orientation::Vec, 3>{{{1, 0, 0}, {0, 0, -1}, {0, 1, 0}}}));
  EXPECT_EQ(o.origin, (store::Orientation::Vec{-3, 4, 5}));
  expectSeries(*source, s, phantom);
}

TEST(Dicom, RescaleKeepsIntegerTypesWhenTheyHoldTheValues) {
  struct Case {
    int bits;
    bool isSigned;
    double slope, intercept;
    ValueType type;
  };
  const Case cases[] = {
      {16, true, 1, 0, ValueType::I16},  // stored as is
      {16, false, 1, 0, ValueType::U16},      {8, false, 1, 0, ValueType::U8},
      {8, false, 2, 10, ValueType::U16},       // [10, 520]
      {8, true, 1, -100, ValueType::I16},      // [-228, 27]
      {16, false, 1, -1024, ValueType::F32},   // [-1024, 64511]: no 16-bit type holds it
      {16, true, 0.5, -3.25, ValueType::F32},  // not integral
  };
  for (const Case& c : cases) {
    ScratchDir dir;
    DicomSeriesSpec s;
    s.dims = {4, 3, 3};
    s.bitsAllocated = c.bits;
    s.isSigned = c.isSigned;
    s.slope = c.slope;
    s.intercept = c.intercept;
    // Stored values 20 - i - 4j + 12k: within every pixel type.
    auto f = [&](const Vec3& ras) { return c.intercept + c.slope * (20 + ras[0] + 4 * ras[1] + 12 * ras[2]); };
    test::writeDicomSeries(dir.path(), s, f);
    auto source = store::openSource(dir.path().string(), {});
    SCOPED_TRACE(source->info().description);
    EXPECT_EQ(source->info().type, c.type);
    expectSeries(*source, s, f);
  }
}

TEST(Dicom, SlicesWithTheirOwnRescaleAreF32) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {3, 3, 3};
  test::writeDicomSeries(dir.path(), s, phantom);
  DicomSeriesSpec other = s;
  other.slope = 2;
  test::writeDicomSlice(dir / "z.dcm", other, 3, phantom);
  auto source = store::openSource(dir.path().string(), {});
  EXPECT_EQ(source->info().type, ValueType::F32);
  EXPECT_EQ(source->info().dims.z, 4);
  const std::vector<double> v = test::readValues(*source, 4);
  EXPECT_EQ(v.back(), std::round(phantom(test::dicomVoxelRas(s, 2, 2, 3)) / 2) * 2);
}

TEST(Dicom, MixedSeriesAreListedAndSeriesPicksOne) {
  ScratchDir dir;
  DicomSeriesSpec a, b;
  a.dims = {4, 4, 3};
  a.seriesUid = "1.2.3.4.100";
  a.description = "first series";
  a.prefix = "a";
  b.dims = {4, 4, 5};
  b.seriesUid = "1.2.3.4.200";
  b.description = "second series";
  b.prefix = "b";
  test::writeDicomSeries(dir.path(), a, phantom);
  const auto bFiles = test::writeDicomSeries(dir.path(), b, phantom);
  expectRefused(openAndRead(dir.path().string()), {dir.path().string(), "2 DICOM image series", "--series", "\nUID",
                                                   "\n1.2.3.4.100", "first series", "\n1.2.3.4.200", "second series"});
  store::SourceOptions pick;
  pick.seriesUid = "1.2.3.4.200";
  auto picked = store::openSource(dir.path().string(), pick);
  expectSeries(*picked, b, phantom);
  pick.seriesUid = "9.9.9";
  expectRefused(openAndRead(dir.path().string(), pick), {"no DICOM image series 9.9.9", "1.2.3.4.100", "1.2.3.4.200"});
  // One file stands for its own series.
  auto one = store::openSource(bFiles[0].string(), {});
  EXPECT_EQ(one->info().dims.z, 5);
  expectRefused(openAndRead(dir.path().string() + "/*.dcm"), {"2 DICOM image series"});
  auto listed = store::openSource(strings(bFiles), {});
  EXPECT_EQ(listed->info().dims.z, 5);
}

TEST(Dicom, GapIsRefusedNamingTheSlicesAroundIt) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {3, 3, 6};
  s.spacing = {1, 1, 2};
  const auto files = test::writeDicomSeries(dir.path(), s, phantom);
  std::filesystem::remove(files[3]);
  expectRefused(openAndRead(dir.path().string()),
                {"uneven slice spacing", files[2].string(), files[4].string(), "4 mm", "2 mm"});
}

TEST(Dicom, UnevenSpacingIsRefused) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {3, 3, 5};
  test::writeDicomSeries(dir.path(), s, phantom);
  DicomSeriesSpec shifted = s;
  shifted.originLps = {0, 0, 0.3};  // slice 5 at 5.3 mm
  test::writeDicomSlice(dir / "last.dcm", shifted, 5, phantom);
  expectRefused(openAndRead(dir.path().string()), {"uneven slice spacing", "last.dcm", "1.3 mm"});
}

TEST(Dicom, DuplicatePositionIsRefused) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {3, 3, 4};
  s.shuffleSeed = 0;
  const auto files = test::writeDicomSeries(dir.path(), s, phantom);
  test::writeDicomSlice(dir / "again.dcm", s, 2, phantom);
  expectRefused(openAndRead(dir.path().string()), {"duplicate slice position", files[2].string(), "again.dcm"});
}

TEST(Dicom, MismatchedSlicesAreRefused) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {4, 3, 3};
  const auto files = test::writeDicomSeries(dir.path(), s, phantom);
  const auto odd = dir / "zz.dcm";  // after the series' files, so the message names it as the odd one
  auto refuseWith = [&](DicomSeriesSpec other, const std::vector<std::string>& words) {
    test::writeDicomSlice(odd, other, 3, phantom);
    std::vector<std::string> all = words;
    all.push_back("zz.dcm");
    expectRefused(openAndRead(dir.path().string()), all);
  };
  DicomSeriesSpec bigger = s;
  bigger.dims = {5, 3, 4};
  refuseWith(bigger, {"size 5x3", "4x3"});
  DicomSeriesSpec eightBit = s;
  eightBit.bitsAllocated = 8;
  refuseWith(eightBit, {"pixel format"});
  DicomSeriesSpec turned = s;
  turned.rowLps = {0.8, 0.6, 0};
  turned.columnLps = {-0.6, 0.8, 0};
  refuseWith(turned, {"ImageOrientationPatient"});
  DicomSeriesSpec finer = s;
  finer.spacing = {0.5, 1, 1};
  refuseWith(finer, {"PixelSpacing"});
}

TEST(Dicom, UnsupportedTransferSyntaxIsRefusedByName) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {4, 4, 2};
  s.transferSyntax = "1.2.840.10008.1.2.4.100";  // MPEG2 Main Profile @ Main Level: video
  test::writeDicomSeries(dir.path(), s, phantom);
  expectRefused(openAndRead(dir.path().string()),
                {"unsupported transfer syntax", "1.2.840.10008.1.2.4.100", "MPEG2", ".dcm"});
}

TEST(Dicom, JpegLsCompressedSeriesDecodes) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {6, 5, 4};
  s.transferSyntax = "jpegls";
  test::writeDicomSeries(dir.path(), s, phantom);
  auto source = store::openSource(dir.path().string(), {});
  EXPECT_NE(source->info().description.find("JPEG-LS"), std::string::npos) << source->info().description;
  expectSeries(*source, s, phantom);
}

TEST(Dicom, ColourMultiFrameAndMissingTagsAreRefusedByName) {
  DicomSeriesSpec s;
  s.dims = {4, 4, 3};
  auto refuse = [&](const std::function<void(const std::filesystem::path&)>& edit,
                    const std::vector<std::string>& words) {
    ScratchDir dir;
    const auto files = test::writeDicomSeries(dir.path(), s, phantom);
    edit(files[1]);
    std::vector<std::string> all = words;
    all.push_back(files[1].string());
    expectRefused(openAndRead(dir.path().string()), all);
  };
  refuse([](const auto& f) { editUs(f, 0x0028, 0x0002, 3); }, {"colour", "SamplesPerPixel 3"});
  refuse([](const auto& f) { editTag(f, 0x0028, 0x0004, gdcm::VR::CS, "PALETTE COLOR"); }, {"colour", "PALETTE"});
  refuse([](const auto& f) { editTag(f, 0x0028, 0x0008, gdcm::VR::IS, "2"); }, {"multi-frame", "NumberOfFrames 2"});
  refuse([](const auto& f) { editTag(f, 0x0020, 0x0032, gdcm::VR::DS, ""); }, {"missing", "ImagePositionPatient"});
  refuse([](const auto& f) { editTag(f, 0x0020, 0x0037, gdcm::VR::DS, ""); }, {"missing", "ImageOrientationPatient"});
  refuse([](const auto& f) { editTag(f, 0x0028, 0x0030, gdcm::VR::DS, ""); }, {"missing", "PixelSpacing"});
  refuse([](const auto& f) { editTag(f, 0x0020, 0x000E, gdcm::VR::UI, ""); }, {"missing", "SeriesInstanceUID"});
  refuse([](const auto& f) { editTag(f, 0x0028, 0x0030, gdcm::VR::DS, "abc\\1"); }, {"PixelSpacing", "not numeric"});
  refuse([](const auto& f) { editUs(f, 0x0028, 0x0100, 32); }, {"BitsAllocated 32"});
}

TEST(Dicom, MalformedFilesAreInputErrorsNotCrashes) {
  ScratchDir dir;
  DicomSeriesSpec s;
  s.dims = {8, 8, 3};
  s.shuffleSeed = 0;
  const auto files = test::writeDicomSeries(dir / "ok", s, phantom);
  test::writeFile(dir / "garbage.dcm", std::string(300, 'x'));
  expectRefused(openAndRead((dir / "garbage.dcm").string()), {"garbage.dcm"});
  // Every truncation of a real file, and of a JPEG-LS one (encapsulated pixel data): an InputError naming it.
  DicomSeriesSpec jpeg = s;
  jpeg.transferSyntax = "jpegls";
  const auto jpegFiles = test::writeDicomSeries(dir / "jpeg", jpeg, phantom);
  for (const auto* series : {&files, &jpegFiles}) {
    const std::filesystem::path victim = (*series)[1];
    const std::vector<char> bytes = test::readFile(victim);
    for (size_t cut = 0; cut < bytes.size(); ++cut) {
      test::writeFile(victim, bytes.data(), cut);
      SCOPED_TRACE("cut at " + std::to_string(cut) + " of " + std::to_string(bytes.size()));
      expectRefused(openAndRead(victim.parent_path().string()), {victim.filename().string()});
    }
    test::writeFile(victim, bytes.data(), bytes.size());
    EXPECT_NO_THROW(openAndRead(victim.parent_path().string())());
  }
}

}  // namespace
}  // namespace voxbrick
