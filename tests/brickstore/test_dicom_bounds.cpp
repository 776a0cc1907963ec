// What a DICOM header can make the reader allocate, bounded before any decoder runs: compressed (RLE, JPEG-LS)
// slices whose Rows x Columns claim gigabytes, a deflated data set that is truncated or inflates without end, and a
// declared slice beyond prep's --memory. Each is refused naming the file and the field, at the memory of an idle
// process; the ingest fuzzer (brickstore/fuzz/fuzz_ingest.py) found the deflated ones.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "InputRefusals.h"
#include "MeasuredRun.h"
#include "brickstore/ingest/Sources.h"
#include "support/DicomSeries.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

namespace fs = std::filesystem;
using test::DicomSeriesSpec;
using test::elementAt;
using test::expectRefused;
using test::openAndRead;
using test::ScratchDir;

double boundsPhantom(const test::Vec3& ras) { return 100 + 3 * ras[0] + 5 * ras[1] + 7 * ras[2]; }

/// 32 x 32 x 4 slices of 16 bits in `syntax` ("", "rle", "jpegls"), files in slice order.
std::vector<fs::path> series(const fs::path& dir, const std::string& syntax) {
  DicomSeriesSpec s;
  s.dims = {32, 32, 4};
  s.shuffleSeed = 0;
  s.transferSyntax = syntax;
  return test::writeDicomSeries(dir, s, boundsPhantom);
}

/// Sets Rows and Columns (US) of every file to `size`, the compressed pixel data left as it is.
void forgeSize(const std::vector<fs::path>& files, uint16_t size) {
  for (const fs::path& f : files) {
    std::vector<char> bytes = test::readFile(f);
    std::memcpy(bytes.data() + elementAt(bytes, 0x0028, 0x0010, "US") + 8, &size, 2);
    std::memcpy(bytes.data() + elementAt(bytes, 0x0028, 0x0011, "US") + 8, &size, 2);
    test::writeFile(f, bytes.data(), bytes.size());
  }
}

/// `voxbrick ARGS` measured: refused (status 1) within 200 MB of an idle process.
void expectCheapRefusal(const std::vector<std::string>& args) {
  const test::MeasuredRun idle = test::runVoxbrickMeasured({"--version"});
  const test::MeasuredRun run = test::runVoxbrickMeasured(args);
  EXPECT_EQ(run.exitCode, 1);
  EXPECT_LT(run.peakMB, idle.peakMB + 200) << "idle " << idle.peakMB << " MB";
  EXPECT_LT(run.seconds, 20);
}

TEST(DicomBounds, RleSliceLargerThanItsFragmentsCanHoldIsRefusedBeforeDecoding) {
  ScratchDir dir;
  const auto files = series(dir / "rle", "rle");
  ASSERT_NO_THROW(openAndRead(dir / "rle")());
  forgeSize(files, 65535);  // 8.6 GB a slice, from a few kilobytes of RLE
  expectRefused(openAndRead(dir / "rle"),
                {files[0].string() + ": Rows 65535 x Columns 65535", "RLE Lossless", "fragments can hold (at 64:1)"});
  // prep's --memory refuses it first, naming the field.
  const std::string out = (dir / "s").string();
  const test::CommandResult r = test::runVoxbrick("prep " + (dir / "rle").string() + " -q -o " + out + " 2>&1");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find(": Rows x Columns declares slices of 65535x65535"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--memory 1024 MB is too small"), std::string::npos) << r.output;
  expectCheapRefusal({"prep", (dir / "rle").string(), "-q", "-o", out});
  EXPECT_FALSE(fs::exists(out));
}

TEST(DicomBounds, JpegLsFrameOfAnotherSizeThanTheHeaderIsRefused) {
  ScratchDir dir;
  const auto files = series(dir / "ls", "jpegls");
  ASSERT_NO_THROW(openAndRead(dir / "ls")());
  forgeSize(files, 40000);
  expectRefused(
      openAndRead(dir / "ls"),
      {files[0].string() + ": the compressed frame's header says 32x32 pixels, but Rows 40000 x Columns 40000"});
  expectCheapRefusal({"prep", (dir / "ls").string(), "--memory", "8192", "-q", "-o", (dir / "s").string()});
}

/// A copy of explicit-VR little-endian `file` as deflated explicit VR little endian, its PixelData value replaced by
/// `pixelBytes` zeros when that is not 0, and cut `cut` bytes short.
void writeDeflated(const fs::path& file, const fs::path& to, uint32_t pixelBytes, size_t cut) {
  const std::vector<char> in = test::readFile(file);
  size_t metaEnd = 132;  // the meta header: explicit VR elements of group 0002 (lengths of 2 or 4 bytes)
  while (in[metaEnd] == 2 && in[metaEnd + 1] == 0) {
    const std::string vr(in.data() + metaEnd + 4, 2);
    const bool isLong = vr == "OB" || vr == "UN";
    uint32_t length = 0;
    std::memcpy(&length, in.data() + metaEnd + (isLong ? 8 : 6), isLong ? 4 : 2);
    metaEnd += (isLong ? 12 : 8) + length;
  }
  std::string meta(in.data(), metaEnd);
  const std::string explicitUid("1.2.840.10008.1.2.1\0", 20), deflatedUid = "1.2.840.10008.1.2.1.99";
  const size_t uidAt = meta.find(explicitUid);
  ASSERT_NE(uidAt, std::string::npos);
  meta.replace(uidAt, explicitUid.size(), deflatedUid);
  const uint16_t uidLength = uint16_t(deflatedUid.size());
  std::memcpy(meta.data() + uidAt - 2, &uidLength, 2);
  uint32_t groupLength = uint32_t(meta.size() - 144);  // after (0002,0000): preamble, DICM and its 12 bytes
  std::memcpy(meta.data() + 140, &groupLength, 4);

  std::vector<char> dataSet(in.begin() + long(metaEnd), in.end());
  if (pixelBytes > 0) {
    const size_t at = elementAt(dataSet, 0x7FE0, 0x0010, "OW");
    dataSet.resize(at + 12);
    std::memcpy(dataSet.data() + at + 8, &pixelBytes, 4);
  }
  z_stream z{};
  ASSERT_EQ(deflateInit2(&z, 6, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::vector<char> out(meta.begin(), meta.end()), buffer(1 << 20), zeros(1 << 20, 0);
  auto pump = [&](const char* data, size_t size, int flush) {
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data));
    z.avail_in = uInt(size);
    do {
      z.next_out = reinterpret_cast<Bytef*>(buffer.data());
      z.avail_out = uInt(buffer.size());
      deflate(&z, flush);
      out.insert(out.end(), buffer.data(), buffer.data() + (buffer.size() - z.avail_out));
    } while (z.avail_out == 0);
  };
  pump(dataSet.data(), dataSet.size(), Z_NO_FLUSH);
  for (uint32_t left = pixelBytes; left > 0;) {
    const uint32_t n = std::min<uint32_t>(left, uint32_t(zeros.size()));
    pump(zeros.data(), n, Z_NO_FLUSH);
    left -= n;
  }
  pump(nullptr, 0, Z_FINISH);
  deflateEnd(&z);
  out.resize(out.size() - cut);
  test::writeFile(to, out.data(), out.size());
}

TEST(DicomBounds, DeflatedDataSetIsWalkedBeforeGdcmReadsIt) {
  ScratchDir dir;
  const auto files = series(dir / "plain", "");
  fs::create_directories(dir / "ok");
  for (const fs::path& f : files) writeDeflated(f, dir / "ok" / f.filename(), 0, 0);
  ASSERT_NO_THROW(openAndRead(dir / "ok")());  // a good deflated series reads

  // Cut short: GDCM (built with assertions) aborted the process.
  fs::copy(dir / "ok", dir / "cut");
  const fs::path cut = dir / "cut" / files[1].filename();
  writeDeflated(files[1], cut, 0, 40);
  expectRefused(openAndRead(dir / "cut"), {cut.string() + ": deflated data set is truncated"});
  expectCheapRefusal({"prep", (dir / "cut").string(), "-q", "-o", (dir / "s").string()});

  // 512 MB of zeros in a 512 KB file: GDCM inflated all of it into memory.
  fs::copy(dir / "ok", dir / "bomb");
  const fs::path bomb = dir / "bomb" / files[2].filename();
  writeDeflated(files[2], bomb, 1u << 29, 0);
  ASSERT_LT(fs::file_size(bomb), 4u << 20);
  expectRefused(openAndRead(dir / "bomb"), {bomb.string() + ": deflated data set inflates to more than 128 MB"});
  expectCheapRefusal({"prep", (dir / "bomb").string(), "-q", "-o", (dir / "s").string()});

  // A short PixelData inside a deflated data set is found as in a plain one.
  fs::copy(dir / "ok", dir / "short");
  const fs::path shortPixels = dir / "short" / files[0].filename();
  writeDeflated(files[0], shortPixels, 1000, 0);
  expectRefused(openAndRead(dir / "short"), {shortPixels.string() + ": PixelData holds 1000 bytes", "needs 2048"});
}

TEST(DicomBounds, DeclaredSliceBeyondMemoryIsRefusedNamingTheField) {
  ScratchDir dir;
  const auto files = series(dir / "ct", "");
  const test::CommandResult r =
      test::runVoxbrick("prep " + (dir / "ct").string() + " --memory 128 -q -o " + (dir / "s").string() + " 2>&1");
  EXPECT_EQ(r.exitCode, 0) << r.output;  // 32 x 32 fits
  forgeSize(files, 8000);  // 128 MB a slice: the pixel data no longer matches either, but --memory is checked first
  const test::CommandResult big =
      test::runVoxbrick("prep " + (dir / "ct").string() + " --memory 256 -q -o " + (dir / "t").string() + " 2>&1");
  EXPECT_EQ(big.exitCode, 1);
  EXPECT_NE(big.output.find(files[0].string() + ": Rows x Columns declares slices of 8000x8000 voxels"),
            std::string::npos)
      << big.output;
  EXPECT_NE(big.output.find("--memory 256 MB is too small"), std::string::npos) << big.output;
}

}  // namespace
}  // namespace voxbrick
