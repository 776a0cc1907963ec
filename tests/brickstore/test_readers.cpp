// Tests of the dense file readers (raw, NRRD, NIfTI-1): round trips of generated files and every kind of bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include "brickstore/format/Errors.h"
#include "brickstore/format/Orientation.h"
#include "brickstore/ingest/Sources.h"
#include "support/TestSupport.h"

namespace {

using namespace voxbrick::store;
using voxbrick::test::gzipBytes;
using voxbrick::test::ScratchDir;
using voxbrick::test::writeFile;
namespace fs = std::filesystem;

using Bytes = std::vector<char>;
using Opener = std::function<std::unique_ptr<VolumeSource>()>;

const Vec3i kSmall{7, 5, 3};
const Vec3i kLarge{37, 29, 23};

template <typename T>
std::vector<T> randomVolume(const Vec3i& dims, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<T> values(static_cast<size_t>(dims.volume()));
  for (T& v : values) {
    if constexpr (std::is_floating_point_v<T>) {
      v = static_cast<T>(std::uniform_real_distribution<double>(-1000.0, 1000.0)(rng));
    } else {
      v = static_cast<T>(rng());
    }
  }
  return values;
}

// Values as a file stores them, in the given byte order.
template <typename T>
Bytes fileBytes(const std::vector<T>& values, bool bigEndian) {
  Bytes out(values.size() * sizeof(T));
  std::memcpy(out.data(), values.data(), out.size());
  if (bigEndian != (std::endian::native == std::endian::big)) {
    for (size_t i = 0; i < out.size(); i += sizeof(T)) std::reverse(out.begin() + i, out.begin() + i + sizeof(T));
  }
  return out;
}

// What a reader must deliver: each value cast to the store type D, or scaled to float.
template <typename D, typename T>
Bytes storeBytes(const std::vector<T>& values, double slope = 1.0, double inter = 0.0, bool scaled = false) {
  std::vector<D> converted(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    converted[i] = scaled ? static_cast<D>(static_cast<double>(values[i]) * slope + inter) : static_cast<D>(values[i]);
  }
  Bytes out(converted.size() * sizeof(D));
  std::memcpy(out.data(), converted.data(), out.size());
  return out;
}

Bytes concat(Bytes a, const Bytes& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

Bytes gzip(const Bytes& data) { return gzipBytes(data.data(), data.size()); }

Bytes textBytes(const std::string& text) { return Bytes(text.begin(), text.end()); }

void writeBytes(const fs::path& path, const Bytes& bytes) { writeFile(path, bytes.data(), bytes.size()); }

Bytes readAllValues(VolumeSource& source, int64_t batch) {
  const VolumeInfo& info = source.info();
  const size_t slice = static_cast<size_t>(info.dims.x * info.dims.y) * valueSize(info.type);
  Bytes out(slice * static_cast<size_t>(info.dims.z));
  for (int64_t z = 0; z < info.dims.z; z += batch) {
    source.readSlices(std::min(batch, info.dims.z - z), out.data() + static_cast<size_t>(z) * slice);
  }
  return out;
}

void expectSameBytes(const Bytes& actual, const Bytes& expected, const std::string& what) {
  ASSERT_EQ(actual.size(), expected.size()) << what;
  auto mismatch = std::mismatch(actual.begin(), actual.end(), expected.begin());
  EXPECT_TRUE(mismatch.first == actual.end())
      << what << ": first difference at byte " << (mismatch.first - actual.begin());
}

// Reads the whole volume in several batch sizes (a fresh source each time) and checks the bytes and the end.
void expectVolume(const Opener& open, const Bytes& expected, const std::string& what) {
  const int64_t dimsZ = open()->info().dims.z;
  for (int64_t batch : {int64_t(1), int64_t(2), int64_t(4), dimsZ}) {
    auto source = open();
    expectSameBytes(readAllValues(*source, batch), expected, what + ", batch " + std::to_string(batch));
    Bytes extra(static_cast<size_t>(source->info().dims.x * source->info().dims.y) * valueSize(source->info().type));
    EXPECT_THROW(source->readSlices(1, extra.data()), InputError) << what;
  }
}

// Runs fn and checks it throws E with a one-line message naming `file` and containing `keyword`.
template <typename E = InputError>
void expectReadError(const std::function<void()>& fn, const std::string& file, const std::string& keyword) {
  try {
    fn();
    ADD_FAILURE() << "no exception; expected one naming " << file << " with '" << keyword << "'";
  } catch (const E& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(file), std::string::npos) << "message does not name " << file << ": " << message;
    EXPECT_NE(message.find(keyword), std::string::npos) << "message lacks '" << keyword << "': " << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << "message is not one line: " << message;
  }
}

// Opens and reads the whole volume, for errors that may show only while reading.
std::function<void()> openAndRead(const Opener& open) {
  return [open] {
    auto source = open();
    readAllValues(*source, 2);
  };
}

// ---------------------------------------------------------------------------------------------------------------
// Raw

SourceOptions rawOptions(const Vec3i& dims, const std::string& type) {
  SourceOptions options;
  options.dims = dims;
  options.type = type;
  return options;
}

template <typename T>
void roundTripRaw(const std::string& type, ValueType expectedType, const Vec3i& dims, bool bigEndian) {
  ScratchDir dir;
  const std::string path = (dir / "vol.raw").string();
  const auto values = randomVolume<T>(dims, 11);
  writeBytes(path, fileBytes(values, bigEndian));
  SourceOptions options = rawOptions(dims, type);
  options.bigEndian = bigEndian;
  auto source = openRawSource(path, options);
  EXPECT_EQ(source->info().dims, dims);
  EXPECT_EQ(source->info().type, expectedType);
  EXPECT_EQ(source->info().spacing, (Vec3d{1, 1, 1}));
  EXPECT_EQ(source->info().background, 0.0);
  expectVolume([&] { return openRawSource(path, options); }, storeBytes<T>(values), type);
}

TEST(RawSource, ReadsEveryTypeInSeveralBatchSizes) {
  for (const Vec3i& dims : {kSmall, kLarge}) {
    for (bool big : {false, true}) {
      roundTripRaw<uint8_t>("u8", ValueType::U8, dims, big);
      roundTripRaw<uint16_t>("u16", ValueType::U16, dims, big);
      roundTripRaw<int16_t>("i16", ValueType::I16, dims, big);
      roundTripRaw<float>("f32", ValueType::F32, dims, big);
    }
  }
}

TEST(RawSource, SkipsHeaderBytesAndTakesGivenSpacing) {
  ScratchDir dir;
  const std::string path = (dir / "vol.raw").string();
  const auto values = randomVolume<uint16_t>(kSmall, 3);
  writeBytes(path, concat(Bytes(100, 'h'), fileBytes(values, false)));
  SourceOptions options = rawOptions(kSmall, "u16");
  options.headerBytes = 100;
  options.spacing = Vec3d{0.5, 2, 3};
  options.spacingGiven = true;
  auto source = openRawSource(path, options);
  EXPECT_EQ(source->info().spacing, (Vec3d{0.5, 2, 3}));
  EXPECT_NE(source->info().description.find("7x5x3"), std::string::npos) << source->info().description;
  expectSameBytes(readAllValues(*source, 3), storeBytes<uint16_t>(values), "header bytes");
}

TEST(RawSource, SizeMismatchNamesBothNumbers) {
  ScratchDir dir;
  const std::string path = (dir / "vol.raw").string();
  writeBytes(path, Bytes(1000));
  expectReadError(
      [&] {
        openRawSource(path, rawOptions({10, 10, 11}, "u8"));
      },
      "vol.raw", "size 1000 bytes does not match --dims 10,10,11 --type u8 (expected 1100 bytes)");
  SourceOptions withHeader = rawOptions({10, 10, 10}, "u8");
  withHeader.headerBytes = 8;
  expectReadError([&] { openRawSource(path, withHeader); }, "vol.raw", "expected 1008 bytes");
}

TEST(RawSource, RejectsBadOptions) {
  ScratchDir dir;
  const std::string path = (dir / "vol.raw").string();
  writeBytes(path, Bytes(105));
  expectReadError([&] { openRawSource(path, rawOptions({7, 0, 3}, "u8")); }, "vol.raw", "zero or negative dims");
  expectReadError([&] { openRawSource(path, rawOptions({7, 5, -3}, "u8")); }, "vol.raw", "zero or negative dims");
  expectReadError([&] { openRawSource(path, rawOptions(kSmall, "f64")); }, "vol.raw", "unsupported voxel type 'f64'");
  expectReadError([&] { openRawSource(path, rawOptions(kSmall, "")); }, "vol.raw", "--type");
  const int64_t huge = int64_t(1) << 40;
  expectReadError([&] { openRawSource(path, rawOptions({huge, huge, huge}, "u8")); }, "vol.raw", "too large");
  SourceOptions negativeHeader = rawOptions(kSmall, "u8");
  negativeHeader.headerBytes = -1;
  expectReadError([&] { openRawSource(path, negativeHeader); }, "vol.raw", "--header-bytes");
  for (double bad : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    SourceOptions badSpacing = rawOptions(kSmall, "u8");
    badSpacing.spacing = Vec3d{1, bad, 1};
    badSpacing.spacingGiven = true;
    expectReadError([&] { openRawSource(path, badSpacing); }, "vol.raw", "positive and finite");
  }
  expectReadError<IoError>([&] { openRawSource((dir / "absent.raw").string(), rawOptions(kSmall, "u8")); },
                           "absent.raw", "No such file");
}

TEST(RawSource, ReadingPastTheLastSliceThrows) {
  ScratchDir dir;
  const std::string path = (dir / "vol.raw").string();
  writeBytes(path, Bytes(105, 1));
  auto source = openRawSource(path, rawOptions(kSmall, "u8"));
  Bytes buffer(35 * 4);
  expectReadError([&] { source->readSlices(4, buffer.data()); }, "vol.raw", "read past the end");
  source->readSlices(2, buffer.data());
  expectReadError([&] { source->readSlices(2, buffer.data()); }, "vol.raw", "read past the end");
}

// ---------------------------------------------------------------------------------------------------------------
// NRRD

std::string sizesText(const Vec3i& dims) {
  return std::to_string(dims.x) + " " + std::to_string(dims.y) + " " + std::to_string(dims.z);
}

std::string nrrdHeader(const std::string& type, const Vec3i& dims, const std::string& encoding, bool bigEndian,
                       const std::string& extra = "") {
  return "NRRD0004\n# written by test_readers\ntype: " + type + "\ndimension: 3\nsizes: " + sizesText(dims) +
         "\nencoding: " + encoding + "\nendian: " + (bigEndian ? "big" : "little") + "\n" + extra;
}

template <typename T, typename D>
void roundTripNrrd(const std::string& spelling, ValueType expectedType, const Vec3i& dims, bool gzipped,
                   bool bigEndian) {
  ScratchDir dir;
  const std::string path = (dir / "scan.nrrd").string();
  const auto values = randomVolume<T>(dims, 5);
  const Bytes data = fileBytes(values, bigEndian);
  writeBytes(path, concat(textBytes(nrrdHeader(spelling, dims, gzipped ? "gzip" : "raw", bigEndian) + "\n"),
                          gzipped ? gzip(data) : data));
  const std::string what = "NRRD '" + spelling + "'" + (gzipped ? " gzip" : " raw") + (bigEndian ? " big" : "");
  auto source = openNrrdSource(path, {});
  EXPECT_EQ(source->info().dims, dims) << what;
  EXPECT_EQ(source->info().type, expectedType) << what;
  expectVolume([&] { return openNrrdSource(path, {}); }, storeBytes<D>(values), what);
}

TEST(NrrdSource, ReadsEveryTypeSpelling) {
  for (const char* s : {"signed char", "int8", "int8_t"})
    roundTripNrrd<int8_t, int16_t>(s, ValueType::I16, kSmall, false, false);
  for (const char* s : {"uchar", "unsigned char", "uint8", "uint8_t"})
    roundTripNrrd<uint8_t, uint8_t>(s, ValueType::U8, kSmall, false, false);
  for (const char* s : {"short", "short int", "signed short", "signed short int", "int16", "int16_t"})
    roundTripNrrd<int16_t, int16_t>(s, ValueType::I16, kSmall, false, false);
  for (const char* s : {"ushort", "unsigned short", "unsigned short int", "uint16", "uint16_t"})
    roundTripNrrd<uint16_t, uint16_t>(s, ValueType::U16, kSmall, false, false);
  for (const char* s : {"int", "signed int", "int32", "int32_t"})
    roundTripNrrd<int32_t, float>(s, ValueType::F32, kSmall, false, false);
  for (const char* s : {"uint", "unsigned int", "uint32", "uint32_t"})
    roundTripNrrd<uint32_t, float>(s, ValueType::F32, kSmall, false, false);
  roundTripNrrd<float, float>("float", ValueType::F32, kSmall, false, false);
  roundTripNrrd<double, float>("double", ValueType::F32, kSmall, false, false);
  roundTripNrrd<uint16_t, uint16_t>("Unsigned  Short", ValueType::U16, kSmall, false, false);
}

TEST(NrrdSource, ReadsGzipAndBigEndianLargeVolumes) {
  for (bool gz : {false, true}) {
    for (bool big : {false, true}) {
      roundTripNrrd<uint8_t, uint8_t>("uchar", ValueType::U8, kLarge, gz, big);
      roundTripNrrd<int8_t, int16_t>("int8", ValueType::I16, kLarge, gz, big);
      roundTripNrrd<uint16_t, uint16_t>("ushort", ValueType::U16, kLarge, gz, big);
      roundTripNrrd<int16_t, int16_t>("short", ValueType::I16, kLarge, gz, big);
      roundTripNrrd<int32_t, float>("int", ValueType::F32, kLarge, gz, big);
      roundTripNrrd<uint32_t, float>("uint", ValueType::F32, kLarge, gz, big);
      roundTripNrrd<float, float>("float", ValueType::F32, kLarge, gz, big);
      roundTripNrrd<double, float>("double", ValueType::F32, kLarge, gz, big);
    }
  }
}

TEST(NrrdSource, DetachedHeaderFindsDataRelativeToItsDirectory) {
  ScratchDir dir;
  fs::create_directories(dir / "hdr" / "data");
  const auto values = randomVolume<uint16_t>(kLarge, 8);
  const Bytes data = fileBytes(values, true);
  writeBytes(dir / "hdr" / "data" / "scan.raw", data);
  writeBytes(dir / "hdr" / "data" / "scan.raw.gz", gzip(data));
  const std::string rawHeader = (dir / "hdr" / "scan.nhdr").string();
  writeFile(rawHeader, nrrdHeader("uint16", kLarge, "raw", true, "data file: data/scan.raw\n"));
  const std::string gzHeader = (dir / "hdr" / "scangz.nhdr").string();
  writeFile(gzHeader, nrrdHeader("uint16", kLarge, "gz", true, "datafile: data/scan.raw.gz\n"));
  const std::string absHeader = (dir / "abs.nhdr").string();
  writeFile(absHeader, nrrdHeader("uint16", kLarge, "raw", true,
                                  "data file: " + (dir / "hdr" / "data" / "scan.raw").string() + "\n\n"));
  for (const std::string& header : {rawHeader, gzHeader, absHeader}) {
    expectVolume([&] { return openNrrdSource(header, {}); }, storeBytes<uint16_t>(values), header);
  }
  const std::string description = openNrrdSource(gzHeader, {})->info().description;
  EXPECT_EQ(description, "NRRD uint16 gzip 37x29x23 (scangz.nhdr)");
}

TEST(NrrdSource, ReadsSpacingFromSpacingsAndSpaceDirections) {
  ScratchDir dir;
  const std::string path = (dir / "s.nrrd").string();
  const Bytes data = fileBytes(randomVolume<uint8_t>(kSmall, 1), false);
  auto spacingOf = [&](const std::string& header) {
    writeBytes(path, concat(textBytes(header + "\n"), data));
    return openNrrdSource(path, {})->info().spacing;
  };
  EXPECT_EQ(spacingOf(nrrdHeader("uchar", kSmall, "raw", false)), (Vec3d{1, 1, 1}));
  EXPECT_EQ(spacingOf(nrrdHeader("uchar", kSmall, "raw", false, "spacings: 0.5 2 3\n")), (Vec3d{0.5, 2, 3}));
  EXPECT_EQ(spacingOf(nrrdHeader("uchar", kSmall, "raw", false, "spacings: 0.5 1 +4\n")), (Vec3d{0.5, 1, 4}));
  // Oblique but orthogonal directions (a sheared set is refused: NrrdOrientation).
  EXPECT_EQ(spacingOf(nrrdHeader("uchar", kSmall, "raw", false,
                                 "space: right-anterior-superior\nspace directions: (0.5,0,0) (0, -3, 4) (0,4,3)\n"
                                 "space origin: (1,2,3)\n")),
            (Vec3d{0.5, 5, 5}));
  const std::string fourD =
      "NRRD0005\ntype: uchar\ndimension: 4\nsizes: 1 7 5 3\nkinds: scalar domain domain "
      "domain\nencoding: raw\nspace dimension: 3\nspace directions: none (2,0,0) (0,3,0) "
      "(0,0,4)\n";
  EXPECT_EQ(spacingOf(fourD), (Vec3d{2, 3, 4}));
  SourceOptions override;
  override.spacing = Vec3d{7, 8, 9};
  override.spacingGiven = true;
  EXPECT_EQ(openNrrdSource(path, override)->info().spacing, (Vec3d{7, 8, 9}));
  expectSameBytes(readAllValues(*openNrrdSource(path, {}), 1), data, "4D with a first axis of size 1");
}

TEST(NrrdSource, HonoursByteSkipAndLineSkip) {
  ScratchDir dir;
  const auto values = randomVolume<int16_t>(kSmall, 4);
  const Bytes data = fileBytes(values, false);
  const Bytes expected = storeBytes<int16_t>(values);
  const std::string attached = (dir / "skip.nrrd").string();
  writeBytes(attached, concat(textBytes(nrrdHeader("short", kSmall, "raw", false, "byte skip: 6\n") + "\n"),
                              concat(Bytes(6, 'x'), data)));
  expectVolume([&] { return openNrrdSource(attached, {}); }, expected, "byte skip 6");

  const std::string atEnd = (dir / "end.nrrd").string();
  writeBytes(atEnd, concat(textBytes(nrrdHeader("short", kSmall, "raw", false, "byte skip: -1\n") + "\n"),
                           concat(Bytes(13, 'x'), data)));
  expectVolume([&] { return openNrrdSource(atEnd, {}); }, expected, "byte skip -1");

  writeBytes(dir / "lines.dat", concat(textBytes("line one\nline two\n"), concat(Bytes(3, 'y'), data)));
  const std::string lines = (dir / "lines.nhdr").string();
  writeFile(lines, nrrdHeader("short", kSmall, "raw", false, "data file: lines.dat\nline skip: 2\nbyte skip: 3\n"));
  expectVolume([&] { return openNrrdSource(lines, {}); }, expected, "line skip 2, byte skip 3");

  // With gzip, lines are skipped in the file and bytes in the decompressed data.
  writeBytes(dir / "lines.gz", concat(textBytes("junk\n"), gzip(concat(Bytes(5, 'z'), data))));
  const std::string gzLines = (dir / "gzlines.nhdr").string();
  writeFile(gzLines, nrrdHeader("short", kSmall, "gzip", false, "data file: lines.gz\nlineskip: 1\nbyteskip: 5\n"));
  expectVolume([&] { return openNrrdSource(gzLines, {}); }, expected, "gzip line skip 1, byte skip 5");
}

TEST(NrrdSource, IgnoresCommentsKeyValuesAndCarriageReturns) {
  ScratchDir dir;
  const std::string path = (dir / "crlf.nrrd").string();
  const auto values = randomVolume<float>(kSmall, 9);
  const std::string header =
      "NRRD0004\r\n# a comment: with a colon\r\ncontent: test volume\r\nType: float\r\ndimension: 3\r\n"
      "sizes: 7 5 3\r\nkinds: domain domain domain\r\nencoding: raw\r\nendian: little\r\nmy key:=my: value\r\n"
      "units: \"mm\" \"mm\" \"mm\"\r\n\r\n";
  writeBytes(path, concat(textBytes(header), fileBytes(values, false)));
  expectVolume([&] { return openNrrdSource(path, {}); }, storeBytes<float>(values), "CRLF header");
}

TEST(NrrdErrors, RejectsMalformedHeaders) {
  ScratchDir dir;
  const std::string path = (dir / "bad.nrrd").string();
  const Bytes data(105, 1);
  auto check = [&](const std::string& header, const std::string& keyword) {
    writeBytes(path, concat(textBytes(header + "\n"), data));
    expectReadError([&] { openNrrdSource(path, {}); }, "bad.nrrd", keyword);
  };
  const std::string base = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 7 5 3\nencoding: raw\n";
  check("P5 7 5\n255", "not a NRRD file");
  check("NRRD0004\ndimension: 3\nsizes: 7 5 3\nencoding: raw\n", "missing required header field 'type'");
  check("NRRD0004\ntype: uchar\nsizes: 7 5 3\nencoding: raw\n", "missing required header field 'dimension'");
  check("NRRD0004\ntype: uchar\ndimension: 3\nencoding: raw\n", "missing required header field 'sizes'");
  check("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 7 5 3\n", "missing required header field 'encoding'");
  check("NRRD0004\ntype: ushort\ndimension: 3\nsizes: 7 5 3\nencoding: raw\n",
        "missing required header field 'endian'");
  check("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 7 5\nencoding: raw\n",
        "header field 'sizes' has 2 values, expected 3");
  check("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 7 five 3\nencoding: raw\n",
        "header field 'sizes' has a bad value 'five'");
  check("NRRD0004\ntype: uchar\ndimension: three\nsizes: 7 5 3\nencoding: raw\n", "'dimension' has a bad value");
  check("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 7 0 3\nencoding: raw\n", "must be positive");
  check("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 7 -5 3\nencoding: raw\n", "must be positive");
  check(base + "spacings: 1 x 1\n", "header field 'spacings' has a bad value 'x'");
  check(base + "spacings: 1 1\n", "header field 'spacings' has 2 values, expected 3");
  check(base + "spacings: 1 0 1\n", "'spacings' of spatial axis 1 is 0, not a spacing in [1e-12, 1e+12]");
  check(base + "space directions: (1,0,0) (0,1,0)\n", "'space directions' has 2 values, expected 3");
  check(base + "space directions: (1,0,0) (0,1,0) (0,0,x)\n", "'space directions' has a bad value");
  check(base + "endian: middle\n", "'endian' has a bad value 'middle'");
  check(base + "type: float\n", "'type' is given twice");
  check(base + "this line has no separator\n", "malformed header line 6");
  check(base + "line skip: -2\n", "'line skip' has a bad value");
  check(base + "byte skip: -2\n", "'byte skip' has a bad value");
  check("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 7 5 3\nencoding: gzip\nbyte skip: -1\n",
        "only allowed with raw encoding");
}

TEST(NrrdErrors, RejectsNon3DAndUnsupportedTypesAndEncodings) {
  ScratchDir dir;
  const std::string path = (dir / "bad.nrrd").string();
  auto check = [&](const std::string& header, const std::string& keyword) {
    writeBytes(path, concat(textBytes(header + "\n"), Bytes(1000, 1)));
    expectReadError([&] { openNrrdSource(path, {}); }, "bad.nrrd", keyword);
  };
  check("NRRD0004\ntype: uchar\ndimension: 2\nsizes: 7 5\nencoding: raw\n", "only 3D scalar volumes are supported");
  check("NRRD0004\ntype: uchar\ndimension: 4\nsizes: 3 7 5 3\nencoding: raw\n", "only 3D scalar volumes are supported");
  check("NRRD0004\ntype: uchar\ndimension: 5\nsizes: 1 1 7 5 3\nencoding: raw\n",
        "only 3D scalar volumes are supported");
  for (std::string type :
       {"int64", "long long", "signed long long int", "ulonglong", "uint64_t", "block", "complex", "half"}) {
    check(nrrdHeader(type, kSmall, "raw", false), "unsupported NRRD type '" + type + "'");
  }
  for (std::string encoding : {"ascii", "text", "hex", "bzip2"}) {
    check(nrrdHeader("uchar", kSmall, encoding, false), "unsupported NRRD encoding '" + encoding + "'");
  }
}

TEST(NrrdErrors, RejectsTruncatedOrOverlongHeaders) {
  ScratchDir dir;
  const std::string path = (dir / "cut.nrrd").string();
  writeFile(path, "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 7 5");
  expectReadError([&] { openNrrdSource(path, {}); }, "cut.nrrd", "truncated or corrupt header");
  writeFile(path, "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 7 5 3\nencoding: raw\n");
  expectReadError([&] { openNrrdSource(path, {}); }, "cut.nrrd", "truncated or corrupt header");
  writeFile(path, "NRRD0004");
  expectReadError([&] { openNrrdSource(path, {}); }, "cut.nrrd", "truncated or corrupt header");
  std::string longHeader = "NRRD0004\n";
  while (longHeader.size() < (size_t(1) << 20) + 100) longHeader += "# a long comment line to make the header huge\n";
  writeFile(path, longHeader + "type: uchar\ndimension: 3\nsizes: 7 5 3\nencoding: raw\n\n" + std::string(105, 'x'));
  expectReadError([&] { openNrrdSource(path, {}); }, "cut.nrrd", "truncated or corrupt header");
  writeFile(path, "");
  expectReadError([&] { openNrrdSource(path, {}); }, "cut.nrrd", "not a NRRD file");
}

TEST(NrrdErrors, RejectsTruncatedAndCorruptData) {
  ScratchDir dir;
  const auto values = randomVolume<uint16_t>(kLarge, 2);
  const Bytes data = fileBytes(values, false);
  const std::string header = nrrdHeader("ushort", kLarge, "raw", false) + "\n";
  const std::string gzHeader = nrrdHeader("ushort", kLarge, "gzip", false) + "\n";

  const std::string raw = (dir / "short.nrrd").string();
  writeBytes(raw, concat(textBytes(header), Bytes(data.begin(), data.end() - 10)));
  expectReadError([&] { openNrrdSource(raw, {}); }, "short.nrrd", "truncated");

  // A complete gzip stream that holds too few bytes.
  const std::string gzShort = (dir / "gzshort.nrrd").string();
  writeBytes(gzShort, concat(textBytes(gzHeader), gzip(Bytes(data.begin(), data.end() - 100))));
  expectReadError(openAndRead([&] { return openNrrdSource(gzShort, {}); }), "gzshort.nrrd", "truncated: expected");

  // A gzip stream cut in the middle.
  const Bytes compressed = gzip(data);
  const std::string gzCut = (dir / "gzcut.nrrd").string();
  writeBytes(gzCut, concat(textBytes(gzHeader), Bytes(compressed.begin(), compressed.begin() + compressed.size() / 2)));
  expectReadError(openAndRead([&] { return openNrrdSource(gzCut, {}); }), "gzcut.nrrd", "truncated");

  // Only the trailer's checksum is missing: the voxels are all there, but the stream is incomplete.
  const std::string gzNoTrailer = (dir / "gznotrailer.nrrd").string();
  writeBytes(gzNoTrailer, concat(textBytes(gzHeader), Bytes(compressed.begin(), compressed.end() - 8)));
  expectReadError(openAndRead([&] { return openNrrdSource(gzNoTrailer, {}); }), "gznotrailer.nrrd", "truncated");

  // Damaged deflate data, and a damaged checksum (found after the last voxel).
  Bytes damaged = compressed;
  for (size_t i = damaged.size() / 3; i < damaged.size() / 3 + 64; ++i) damaged[i] = static_cast<char>(0xff);
  const std::string gzBad = (dir / "gzbad.nrrd").string();
  writeBytes(gzBad, concat(textBytes(gzHeader), damaged));
  expectReadError(openAndRead([&] { return openNrrdSource(gzBad, {}); }), "gzbad.nrrd", "corrupt gzip data");
  Bytes badCrc = compressed;
  badCrc[badCrc.size() - 8] = static_cast<char>(badCrc[badCrc.size() - 8] ^ 0x55);
  const std::string gzCrc = (dir / "gzcrc.nrrd").string();
  writeBytes(gzCrc, concat(textBytes(gzHeader), badCrc));
  expectReadError(openAndRead([&] { return openNrrdSource(gzCrc, {}); }), "gzcrc.nrrd", "corrupt gzip data");
  const std::string notGzip = (dir / "notgz.nrrd").string();
  writeBytes(notGzip, concat(textBytes(gzHeader), data));
  expectReadError(openAndRead([&] { return openNrrdSource(notGzip, {}); }), "notgz.nrrd", "corrupt gzip data");
}

TEST(NrrdErrors, RejectsMissingOrMultipleDataFiles) {
  ScratchDir dir;
  const std::string path = (dir / "det.nhdr").string();
  writeFile(path, nrrdHeader("uchar", kSmall, "raw", false, "data file: nothere.raw\n"));
  expectReadError([&] { openNrrdSource(path, {}); }, "det.nhdr", "data file 'nothere.raw' not found");
  writeFile(path, nrrdHeader("uchar", kSmall, "raw", false, "data file: LIST\nslice0.raw\nslice1.raw\n"));
  expectReadError([&] { openNrrdSource(path, {}); }, "det.nhdr", "only a single data file is supported");
  writeFile(path, nrrdHeader("uchar", kSmall, "raw", false, "data file: slice%03d.raw 0 2 1\n"));
  expectReadError([&] { openNrrdSource(path, {}); }, "det.nhdr", "only a single data file is supported");
  writeBytes(dir / "small.raw", Bytes(50));
  writeFile(path, nrrdHeader("uchar", kSmall, "raw", false, "data file: small.raw\n"));
  expectReadError([&] { openNrrdSource(path, {}); }, "small.raw", "truncated");
}

// ---------------------------------------------------------------------------------------------------------------
// NIfTI-1

struct NiftiSpec {
  int32_t sizeofHdr = 348;
  std::array<int16_t, 8> dim{3, 1, 1, 1, 1, 1, 1, 1};
  int16_t datatype = 2;
  int16_t bitpix = 8;
  std::array<float, 8> pixdim{1, 1, 1, 1, 1, 1, 1, 1};
  float voxOffset = 352;
  float slope = 0;
  float inter = 0;
  std::string magic = std::string("n+1\0", 4);
  bool bigEndian = false;
  int16_t qformCode = 0, sformCode = 0;
  std::array<float, 6> quatern{0, 0, 0, 0, 0, 0};                  ///< quatern_b, c, d, qoffset_x, y, z
  std::array<float, 12> srow{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  ///< srow_x, srow_y, srow_z
};

template <typename T>
void put(Bytes& bytes, size_t offset, T value, bool bigEndian) {
  Bytes field = fileBytes(std::vector<T>{value}, bigEndian);
  std::copy(field.begin(), field.end(), bytes.begin() + static_cast<std::ptrdiff_t>(offset));
}

Bytes niftiFile(const NiftiSpec& s, const Vec3i& dims, const Bytes& data) {
  Bytes file(std::max<size_t>(352, static_cast<size_t>(s.voxOffset)), 0);
  put<int32_t>(file, 0, s.sizeofHdr, s.bigEndian);
  std::array<int16_t, 8> dim = s.dim;
  dim[1] = static_cast<int16_t>(dims.x);
  dim[2] = static_cast<int16_t>(dims.y);
  dim[3] = static_cast<int16_t>(dims.z);
  for (size_t i = 0; i < 8; ++i) put<int16_t>(file, 40 + 2 * i, dim[i], s.bigEndian);
  put<int16_t>(file, 70, s.datatype, s.bigEndian);
  put<int16_t>(file, 72, s.bitpix, s.bigEndian);
  for (size_t i = 0; i < 8; ++i) put<float>(file, 76 + 4 * i, s.pixdim[i], s.bigEndian);
  put<float>(file, 108, s.voxOffset, s.bigEndian);
  put<float>(file, 112, s.slope, s.bigEndian);
  put<float>(file, 116, s.inter, s.bigEndian);
  put<int16_t>(file, 252, s.qformCode, s.bigEndian);
  put<int16_t>(file, 254, s.sformCode, s.bigEndian);
  for (size_t i = 0; i < 6; ++i) put<float>(file, 256 + 4 * i, s.quatern[i], s.bigEndian);
  for (size_t i = 0; i < 12; ++i) put<float>(file, 280 + 4 * i, s.srow[i], s.bigEndian);
  std::copy(s.magic.begin(), s.magic.end(), file.begin() + 344);
  return concat(file, data);
}

template <typename T, typename D>
void roundTripNifti(int16_t datatype, ValueType expectedType, const Vec3i& dims, bool gzipped, bool bigEndian) {
  ScratchDir dir;
  const std::string path = (dir / (gzipped ? "img.nii.gz" : "img.nii")).string();
  const auto values = randomVolume<T>(dims, 6);
  NiftiSpec spec;
  spec.datatype = datatype;
  spec.bitpix = static_cast<int16_t>(8 * sizeof(T));
  spec.bigEndian = bigEndian;
  const Bytes file = niftiFile(spec, dims, fileBytes(values, bigEndian));
  writeBytes(path, gzipped ? gzip(file) : file);
  const std::string what =
      "NIfTI datatype " + std::to_string(datatype) + (gzipped ? " gz" : "") + (bigEndian ? " big" : "");
  auto source = openNiftiSource(path, {});
  EXPECT_EQ(source->info().dims, dims) << what;
  EXPECT_EQ(source->info().type, expectedType) << what;
  expectVolume([&] { return openNiftiSource(path, {}); }, storeBytes<D>(values), what);
}

TEST(NiftiSource, ReadsEveryDatatypePlainGzipAndBigEndian) {
  for (const Vec3i& dims : {kSmall, kLarge}) {
    for (bool gz : {false, true}) {
      for (bool big : {false, true}) {
        roundTripNifti<uint8_t, uint8_t>(2, ValueType::U8, dims, gz, big);
        roundTripNifti<int16_t, int16_t>(4, ValueType::I16, dims, gz, big);
        roundTripNifti<int32_t, float>(8, ValueType::F32, dims, gz, big);
        roundTripNifti<float, float>(16, ValueType::F32, dims, gz, big);
        roundTripNifti<double, float>(64, ValueType::F32, dims, gz, big);
        roundTripNifti<int8_t, int16_t>(256, ValueType::I16, dims, gz, big);
        roundTripNifti<uint16_t, uint16_t>(512, ValueType::U16, dims, gz, big);
        roundTripNifti<uint32_t, float>(768, ValueType::F32, dims, gz, big);
      }
    }
  }
}

TEST(NiftiSource, AppliesSclSlopeAndInter) {
  ScratchDir dir;
  const std::string path = (dir / "scaled.nii").string();
  const auto values = randomVolume<int16_t>(kLarge, 12);
  NiftiSpec spec;
  spec.datatype = 4;
  spec.bitpix = 16;
  auto openWith = [&](float slope, float inter) {
    spec.slope = slope;
    spec.inter = inter;
    writeBytes(path, niftiFile(spec, kLarge, fileBytes(values, false)));
    return openNiftiSource(path, {});
  };
  auto scaled = openWith(0.5f, -3.0f);
  EXPECT_EQ(scaled->info().type, ValueType::F32);
  EXPECT_NE(scaled->info().description.find("scaled"), std::string::npos) << scaled->info().description;
  expectVolume([&] { return openNiftiSource(path, {}); }, storeBytes<float>(values, 0.5, -3.0, true), "scaled");
  EXPECT_EQ(openWith(1.0f, 0.0f)->info().type, ValueType::I16);  // identity scaling keeps the type
  EXPECT_EQ(openWith(0.0f, 5.0f)->info().type, ValueType::I16);  // slope 0 means "not scaled"
  EXPECT_EQ(openWith(NAN, 5.0f)->info().type, ValueType::I16);
  auto offsetOnly = openWith(1.0f, 100.0f);
  EXPECT_EQ(offsetOnly->info().type, ValueType::F32);
  expectSameBytes(readAllValues(*offsetOnly, 5), storeBytes<float>(values, 1.0, 100.0, true), "inter only");

  // Big-endian scale factors are swapped too.
  spec.bigEndian = true;
  spec.slope = 2.0f;
  spec.inter = 1.0f;
  writeBytes(path, niftiFile(spec, kLarge, fileBytes(values, true)));
  expectSameBytes(readAllValues(*openNiftiSource(path, {}), 3), storeBytes<float>(values, 2.0, 1.0, true),
                  "big scaled");
}

TEST(NiftiSource, ReadsSpacingDimsAndOffsets) {
  ScratchDir dir;
  const std::string path = (dir / "geom.nii").string();
  const auto values = randomVolume<uint8_t>(kSmall, 13);
  NiftiSpec spec;
  spec.pixdim = {-1, 0.5f, 2.0f, 1.0f, 2.5f, 0, 0, 0};
  spec.dim = {5, 0, 0, 0, 1, 1, 1, 1};
  spec.voxOffset = 416;  // extensions between header and data
  writeBytes(path, niftiFile(spec, kSmall, fileBytes(values, false)));
  auto source = openNiftiSource(path, {});
  EXPECT_EQ(source->info().dims, kSmall);
  EXPECT_EQ(source->info().spacing, (Vec3d{0.5, 2.0, 1.0}));
  EXPECT_EQ(source->info().description, "NIfTI-1 uint8 7x5x3 (geom.nii)");
  expectSameBytes(readAllValues(*source, 3), storeBytes<uint8_t>(values), "vox_offset 416");

  SourceOptions override;
  override.spacing = Vec3d{3, 3, 3};
  override.spacingGiven = true;
  EXPECT_EQ(openNiftiSource(path, override)->info().spacing, (Vec3d{3, 3, 3}));

  // Gzip is recognised by its magic bytes, whatever the name says.
  spec.dim = {4, 0, 0, 0, 1, 1, 1, 1};
  const std::string disguised = (dir / "disguised.nii").string();
  writeBytes(disguised, gzip(niftiFile(spec, kSmall, fileBytes(values, false))));
  auto fromGzip = openNiftiSource(disguised, {});
  EXPECT_NE(fromGzip->info().description.find("gzip"), std::string::npos) << fromGzip->info().description;
  expectSameBytes(readAllValues(*fromGzip, 2), storeBytes<uint8_t>(values), "gzip named .nii");
}

TEST(NiftiErrors, RejectsBadHeaders) {
  ScratchDir dir;
  const std::string path = (dir / "bad.nii").string();
  const Bytes data(7 * 5 * 3 * 8, 0);
  auto check = [&](const NiftiSpec& spec, const std::string& keyword) {
    writeBytes(path, niftiFile(spec, kSmall, data));
    expectReadError([&] { openNiftiSource(path, {}); }, "bad.nii", keyword);
  };
  writeFile(path, std::string(400, 'x'));
  expectReadError([&] { openNiftiSource(path, {}); }, "bad.nii", "not a NIfTI-1 file");
  writeFile(path, "ab");
  expectReadError([&] { openNiftiSource(path, {}); }, "bad.nii", "not a NIfTI-1 file");
  const Bytes headerOnly = niftiFile({}, kSmall, {});
  writeBytes(path, Bytes(headerOnly.begin(), headerOnly.begin() + 200));
  expectReadError([&] { openNiftiSource(path, {}); }, "bad.nii", "truncated header (200 of 348 bytes)");

  NiftiSpec spec;
  spec.magic = std::string("ni1\0", 4);
  check(spec, "NIfTI-1 .hdr/.img pair");
  spec.magic = std::string("abc\0", 4);
  check(spec, "not a NIfTI-1 file");
  spec = {};
  spec.sizeofHdr = 540;
  check(spec, "NIfTI-2");
  spec.sizeofHdr = 100;
  check(spec, "not a NIfTI-1 file");

  spec = {};
  spec.datatype = 32;
  spec.bitpix = 64;
  check(spec, "unsupported NIfTI datatype 32 (complex64)");
  spec.datatype = 128;
  spec.bitpix = 24;
  check(spec, "unsupported NIfTI datatype 128 (RGB24)");
  spec.datatype = 1024;
  spec.bitpix = 64;
  check(spec, "unsupported NIfTI datatype 1024 (int64)");
  spec.datatype = 4;
  spec.bitpix = 8;
  check(spec, "has bitpix 8, expected 16");

  spec = {};
  spec.voxOffset = 0;
  check(spec, "bad vox_offset");
  spec.voxOffset = 352.5f;
  check(spec, "bad vox_offset");

  spec = {};
  spec.dim = {4, 0, 0, 0, 2, 1, 1, 1};
  check(spec, "only 3D scalar volumes are supported");
  spec.dim = {2, 0, 0, 0, 1, 1, 1, 1};
  check(spec, "only 3D scalar volumes are supported");
  spec.dim = {9, 0, 0, 0, 1, 1, 1, 1};
  check(spec, "bad dim[0]");
  spec = {};
  writeBytes(path, niftiFile(spec, {7, 0, 3}, data));
  expectReadError([&] { openNiftiSource(path, {}); }, "bad.nii", "zero or negative dims");
  writeBytes(path, niftiFile(spec, {7, -5, 3}, data));
  expectReadError([&] { openNiftiSource(path, {}); }, "bad.nii", "zero or negative dims");
}

TEST(NiftiErrors, RejectsTruncatedAndCorruptData) {
  ScratchDir dir;
  const auto values = randomVolume<float>(kLarge, 14);
  NiftiSpec spec;
  spec.datatype = 16;
  spec.bitpix = 32;
  const Bytes file = niftiFile(spec, kLarge, fileBytes(values, false));

  const std::string plain = (dir / "cut.nii").string();
  writeBytes(plain, Bytes(file.begin(), file.end() - 4));
  expectReadError([&] { openNiftiSource(plain, {}); }, "cut.nii", "truncated");

  const std::string gzShort = (dir / "short.nii.gz").string();
  writeBytes(gzShort, gzip(Bytes(file.begin(), file.end() - 1000)));
  expectReadError(openAndRead([&] { return openNiftiSource(gzShort, {}); }), "short.nii.gz", "truncated: expected");

  const Bytes compressed = gzip(file);
  const std::string gzCut = (dir / "gzcut.nii.gz").string();
  writeBytes(gzCut, Bytes(compressed.begin(), compressed.begin() + compressed.size() * 2 / 3));
  expectReadError(openAndRead([&] { return openNiftiSource(gzCut, {}); }), "gzcut.nii.gz", "truncated");

  Bytes damaged = compressed;
  for (size_t i = damaged.size() / 2; i < damaged.size() / 2 + 64; ++i) damaged[i] = static_cast<char>(0xff);
  const std::string gzBad = (dir / "gzbad.nii.gz").string();
  writeBytes(gzBad, damaged);
  expectReadError(openAndRead([&] { return openNiftiSource(gzBad, {}); }), "gzbad.nii.gz", "corrupt gzip data");

  // A gzip stream corrupt from its first bytes fails while reading the header.
  Bytes badHeader = compressed;
  badHeader[2] = 9;  // compression method other than deflate
  const std::string gzHdr = (dir / "gzhdr.nii.gz").string();
  writeBytes(gzHdr, badHeader);
  expectReadError([&] { openNiftiSource(gzHdr, {}); }, "gzhdr.nii.gz", "corrupt gzip data");
}

TEST(NiftiSource, ReadsTheRealMriTemplate) {
  const std::string path = "/usr/share/mricron/templates/ch2better.nii.gz";
  ASSERT_TRUE(fs::exists(path)) << path << " is missing: install the mricron-data package (scripts/setup.sh)";
  auto source = openNiftiSource(path, {});
  const VolumeInfo& info = source->info();
  EXPECT_EQ(info.dims, (Vec3i{301, 370, 316}));
  EXPECT_EQ(info.spacing, (Vec3d{0.5, 0.5, 0.5}));
  EXPECT_EQ(info.type, ValueType::U8);
  EXPECT_EQ(info.background, 0.0);
  EXPECT_EQ(info.description, "NIfTI-1 uint8 gzip 301x370x316 (ch2better.nii.gz)");
  const Bytes voxels = readAllValues(*source, 40);
  const auto nonZero = std::count_if(voxels.begin(), voxels.end(), [](char v) { return v != 0; });
  EXPECT_GT(nonZero, static_cast<std::ptrdiff_t>(voxels.size() / 10)) << "the brain should fill much of the volume";
  EXPECT_LT(nonZero, static_cast<std::ptrdiff_t>(voxels.size())) << "the background should be zero";
}

// ---------------------------------------------------------------------------------------------------------------
// Orientation

void expectAxes(const Orientation& o, const std::array<Orientation::Vec, 3>& axes, const Orientation::Vec& origin,
                const std::string& what) {
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) EXPECT_NEAR(o.axes[a][b], axes[a][b], 1e-6) << what << " axis " << a;
  for (int b = 0; b < 3; ++b) EXPECT_NEAR(o.origin[b], origin[b], 1e-4) << what << " origin";
}

// The NIfTI file `spec` describes (dims 4x3x2, u8) opened as a source.
std::unique_ptr<VolumeSource> openNifti(const ScratchDir& dir, const NiftiSpec& spec, const SourceOptions& o = {}) {
  const std::string path = (dir / "o.nii").string();
  writeBytes(path, niftiFile(spec, {4, 3, 2}, Bytes(24, 1)));
  return openNiftiSource(path, o);
}

TEST(NiftiOrientation, SformWinsOverQformAndGivesSpacing) {
  ScratchDir dir;
  NiftiSpec spec;
  spec.pixdim = {1, 9, 9, 9, 1, 1, 1, 1};
  spec.sformCode = 1;
  spec.qformCode = 1;  // ignored: the sform takes precedence
  spec.quatern = {0, 0, 1, 0, 0, 0};
  // i towards the left (x flipped) with 2 mm, j anterior 3 mm, k superior 4 mm; voxel 0 at (10, -20, 30).
  spec.srow = {-2, 0, 0, 10, 0, 3, 0, -20, 0, 0, 4, 30};
  auto source = openNifti(dir, spec);
  expectAxes(source->info().orientation, {{{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}, {10, -20, 30}, "sform");
  EXPECT_TRUE(source->info().orientation.patient);
  EXPECT_EQ(source->info().spacing, (Vec3d{2, 3, 4}));
  EXPECT_EQ(axesLetters(source->info().orientation), "LAS");
  // --spacing replaces the spacing only.
  SourceOptions o;
  o.spacingGiven = true;
  o.spacing = {1, 1, 1};
  auto overridden = openNifti(dir, spec, o);
  EXPECT_EQ(overridden->info().spacing, (Vec3d{1, 1, 1}));
  expectAxes(overridden->info().orientation, {{{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}, {10, -20, 30}, "sform, --spacing");
}

TEST(NiftiOrientation, QformQuaternionWithQfac) {
  ScratchDir dir;
  NiftiSpec spec;
  spec.qformCode = 1;
  spec.pixdim = {-1, 2, 3, 4, 1, 1, 1, 1};  // qfac -1: k flipped
  // 90 degrees about z: (b, c, d) = (0, 0, sin 45); i -> +y, j -> -x.
  spec.quatern = {0, 0, float(std::sqrt(0.5)), 5, 6, 7};
  auto source = openNifti(dir, spec);
  expectAxes(source->info().orientation, {{{0, 1, 0}, {-1, 0, 0}, {0, 0, -1}}}, {5, 6, 7}, "qform");
  EXPECT_NEAR(source->info().spacing.x, 2, 1e-6);  // the float quaternion's rotation is unit to about 1e-7
  EXPECT_NEAR(source->info().spacing.y, 3, 1e-6);
  EXPECT_NEAR(source->info().spacing.z, 4, 1e-6);
  EXPECT_EQ(axesLetters(source->info().orientation), "ALI");
  // Neither code: the identity, no patient frame.
  spec.qformCode = 0;
  auto plain = openNifti(dir, spec);
  EXPECT_EQ(plain->info().orientation, Orientation{});
}

TEST(NiftiOrientation, ShearIsRefusedAndRoundOffCorrected) {
  ScratchDir dir;
  NiftiSpec spec;
  spec.sformCode = 2;
  spec.srow = {1, 0.2f, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  // j leans 11 degrees towards i
  try {
    openNifti(dir, spec);
    ADD_FAILURE() << "a sheared sform was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("index axes i and j are 78.69"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sheared"), std::string::npos) << e.what();
  }
  spec.srow = {1, 1e-5f, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  // float round-off: made orthonormal
  const Orientation o = openNifti(dir, spec)->info().orientation;
  EXPECT_NEAR(o.axes[0][0] * o.axes[1][0] + o.axes[0][1] * o.axes[1][1] + o.axes[0][2] * o.axes[1][2], 0, 1e-15);
  spec.srow = {0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  // i has no direction
  expectReadError([&] { openNifti(dir, spec); }, "o.nii", "index axis i (0, 0, 0) is not a finite non-zero vector");
}

TEST(NrrdOrientation, SpacesDirectionsAndOriginBecomeRas) {
  ScratchDir dir;
  const std::string path = (dir / "o.nrrd").string();
  auto open = [&](const std::string& extra) {
    writeBytes(path, concat(textBytes(nrrdHeader("uchar", {4, 3, 2}, "raw", false, extra) + "\n"), Bytes(24, 1)));
    return openNrrdSource(path, {});
  };
  // LPS: x and y negate (LPS +x is towards the left, RAS -x).
  auto lps = open(
      "space: left-posterior-superior\nspace directions: (2,0,0) (0,3,0) (0,0,4)\n"
      "space origin: (10,20,30)\n");
  expectAxes(lps->info().orientation, {{{-1, 0, 0}, {0, -1, 0}, {0, 0, 1}}}, {-10, -20, 30}, "LPS");
  EXPECT_EQ(lps->info().spacing, (Vec3d{2, 3, 4}));
  EXPECT_TRUE(lps->info().orientation.patient);
  EXPECT_EQ(axesLetters(lps->info().orientation), "LPS");
  auto ras = open("space: RAS\nspace directions: (0,2,0) (3,0,0) (0,0,-4)\n");
  expectAxes(ras->info().orientation, {{{0, 1, 0}, {1, 0, 0}, {0, 0, -1}}}, {0, 0, 0}, "RAS");
  auto scanner = open("space: scanner-xyz\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n");
  EXPECT_FALSE(scanner->info().orientation.patient);
  auto none = open("spacings: 1 2 3\n");
  EXPECT_EQ(none->info().orientation, Orientation{});
  expectReadError([&] { open("space: right-anterior-superior-time\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n"); },
                  "o.nrrd", "header field 'space' has a bad value");
  expectReadError([&] { open("space: RAS\nspace directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (1,2)\n"); },
                  "o.nrrd", "'space origin'");
  expectReadError([&] { open("space: RAS\nspace directions: (1,0,0) (1,1,0) (0,0,1)\n"); }, "o.nrrd", "sheared");
}

}  // namespace
