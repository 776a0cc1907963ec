// Damaged DICOM series: pixel data that does not match its header (short, long, odd, Rows changed), a transfer
// syntax that does not match the pixel data, and a value representation that is none of DICOM's are refused naming
// the file and the field, cheaply, and without touching the store that prep would replace.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "InputRefusals.h"
#include "MeasuredRun.h"
#include "brickstore/format/Errors.h"
#include "brickstore/ingest/Sources.h"
#include "brickstore/ingest/dicom/DicomStructure.h"
#include "support/DicomSeries.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::DicomSeriesSpec;
using test::elementAt;
using test::expectRefused;
using test::openAndRead;
using test::ScratchDir;

double refusalPhantom(const test::Vec3& ras) { return 100 + 3 * ras[0] + 5 * ras[1] + 7 * ras[2]; }

/// 32 x 32 x 6 slices of 16 bits (2048 bytes of pixels a file), files named in slice order.
DicomSeriesSpec spec() {
  DicomSeriesSpec s;
  s.dims = {32, 32, 6};
  s.shuffleSeed = 0;
  return s;
}

/// Rewrites `file` with its PixelData holding `length` bytes (the first bytes of the old value, then zeros).
void setPixelDataLength(const std::filesystem::path& file, uint32_t length) {
  std::vector<char> bytes = test::readFile(file);
  const size_t at = elementAt(bytes, 0x7FE0, 0x0010, "OW");
  bytes.resize(at + 12 + length, 0);
  std::memcpy(bytes.data() + at + 8, &length, 4);
  test::writeFile(file, bytes.data(), bytes.size());
}

/// Rewrites `file` with Rows (0028,0010) set to `rows`, the pixel data left as it is.
void setRows(const std::filesystem::path& file, uint16_t rows) {
  std::vector<char> bytes = test::readFile(file);
  std::memcpy(bytes.data() + elementAt(bytes, 0x0028, 0x0010, "US") + 8, &rows, 2);
  test::writeFile(file, bytes.data(), bytes.size());
}

/// Rewrites `file` with the value representation of an element replaced by `to`.
void setVr(const std::filesystem::path& file, uint16_t group, uint16_t element, const char* from, const char* to) {
  std::vector<char> bytes = test::readFile(file);
  std::memcpy(bytes.data() + elementAt(bytes, group, element, from) + 4, to, 2);
  test::writeFile(file, bytes.data(), bytes.size());
}

TEST(DicomRefusals, PixelDataNotMatchingTheHeaderIsRefusedNamingTheFile) {
  auto refuse = [](const std::function<void(const std::vector<std::filesystem::path>&)>& damage,
                   const std::vector<std::string>& words) {
    ScratchDir dir;
    const auto files = test::writeDicomSeries(dir / "ct", spec(), refusalPhantom);
    damage(files);
    std::vector<std::string> all = words;
    all.push_back(files[3].string() + ": ");
    expectRefused(openAndRead(dir / "ct"), all);
  };
  const std::string geometry = "(Rows 32 x Columns 32 x 2 bytes (BitsAllocated 16) x SamplesPerPixel 1";
  refuse([](const auto& f) { setPixelDataLength(f[3], 1000); }, {"PixelData holds 1000 bytes", "needs 2048", geometry});
  refuse([](const auto& f) { setPixelDataLength(f[3], 2047); }, {"PixelData holds 2047 bytes", "needs 2048"});
  refuse([](const auto& f) { setPixelDataLength(f[3], 2050); }, {"PixelData holds 2050 bytes", "needs 2048"});
  refuse([](const auto& f) { setRows(f[3], 33); }, {"PixelData holds 2048 bytes", "needs 2112", "Rows 33"});
  refuse([](const auto& f) { setRows(f[3], 16); }, {"PixelData holds 2048 bytes", "needs 1024", "Rows 16"});
}

TEST(DicomRefusals, RowsChangedInEverySliceIsRefused) {
  ScratchDir dir;
  const auto files = test::writeDicomSeries(dir / "ct", spec(), refusalPhantom);
  for (const auto& f : files) setRows(f, 31);
  expectRefused(openAndRead(dir / "ct"), {".dcm: PixelData holds 2048 bytes", "needs 1984", "Rows 31"});
}

TEST(DicomRefusals, AnAbsurdPixelSpacingIsRefusedBeforeItReachesTheWorldTransform) {
  // 1e308 mm is finite but beyond what a world transform can invert (OpenVDB's words would be "singular matrix").
  ScratchDir dir;
  DicomSeriesSpec huge = spec();
  huge.spacing = {1e308, 1, 1};
  test::writeDicomSeries(dir / "huge", huge, refusalPhantom);
  expectRefused(openAndRead(dir / "huge"), {"huge", "spacing", "[1e-12, 1e12]"});
}

TEST(DicomRefusals, TransferSyntaxNotMatchingThePixelDataIsRefused) {
  ScratchDir dir;
  DicomSeriesSpec rle = spec();
  rle.transferSyntax = "1.2.840.10008.1.2.5";  // RLE Lossless over native pixels
  const auto files = test::writeDicomSeries(dir / "rle", rle, refusalPhantom);
  expectRefused(openAndRead(dir / "rle"), {".dcm: transfer syntax 1.2.840.10008.1.2.5 (RLE Lossless)",
                                           "needs encapsulated (compressed) pixel data", "2048 bytes of native"});
  store::DicomLayout encapsulated;
  encapsulated.walked = encapsulated.hasPixelData = encapsulated.encapsulated = true;
  const store::DicomPixelFormat native{32, 32, 1, 1, 16, false, "1.2.840.10008.1.2.1 (Explicit VR Little Endian)", ""};
  expectRefused([&] { store::checkPixelData("x.dcm", encapsulated, native); },
                {"x.dcm: transfer syntax 1.2.840.10008.1.2.1", "needs native pixel data", "encapsulated"});
  store::DicomLayout none;
  none.walked = true;
  expectRefused([&] { store::checkPixelData("x.dcm", none, native); }, {"x.dcm: no PixelData (7FE0,0010)"});
  // An odd 8-bit size may carry its padding byte.
  store::DicomLayout padded;
  padded.walked = padded.hasPixelData = true;
  padded.pixelBytes = 10;
  EXPECT_NO_THROW(store::checkPixelData("x.dcm", padded, {3, 3, 1, 1, 8, false, "native", ""}));
}

TEST(DicomRefusals, AnInvalidValueRepresentationIsRefusedCheaply) {
  ScratchDir dir;
  const auto files = test::writeDicomSeries(dir / "ct", spec(), refusalPhantom);
  setVr(files[3], 0x0028, 0x1053, "DS", "XX");
  expectRefused(openAndRead(dir / "ct"),
                {files[3].string() + ": malformed DICOM file", "(0028,1053)", "no valid value representation", "'XX'"});
  const auto run = test::runVoxbrickMeasured({"prep", (dir / "ct").string(), "-q", "-o", (dir / "s").string()});
  EXPECT_EQ(run.exitCode, 1);
  EXPECT_LT(run.peakMB, 400);
  EXPECT_LT(run.seconds, 5);
  EXPECT_FALSE(std::filesystem::exists(dir / "s"));
  setVr(files[3], 0x0028, 0x1053, "XX", "DS");
  setVr(files[2], 0x0002, 0x0013, "SH", "XX");  // in the meta header, where GDCM asserts
  expectRefused(openAndRead(dir / "ct"), {files[2].string() + ": malformed DICOM file", "(0002,0013)", "'XX'"});
}

std::map<std::string, std::vector<char>> filesUnder(const std::filesystem::path& dir) {
  std::map<std::string, std::vector<char>> out;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out[e.path().string()] = test::readFile(e.path());
  return out;
}

TEST(DicomRefusals, ForcedPrepOfADamagedSeriesLeavesTheStoreUntouched) {
  ScratchDir dir;
  const auto files = test::writeDicomSeries(dir / "ct", spec(), refusalPhantom);
  const std::string store = (dir / "store").string();
  auto r = test::runVoxbrick("prep " + (dir / "ct").string() + " --brick 8 -q -o " + store);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const auto before = filesUnder(dir / "store");
  setPixelDataLength(files[3], 1000);
  r = test::runVoxbrick("prep " + (dir / "ct").string() + " --brick 8 -q --force -o " + store);
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find(files[3].string() + ": PixelData holds 1000 bytes"), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_TRUE(filesUnder(dir / "store") == before);
}

}  // namespace
}  // namespace voxbrick
