// Damaged OpenVDB files: a header field that claims more than the file holds is refused by name, in milliseconds
// and without the gigabytes OpenVDB would allocate for it. The files are real ones written by OpenVDB, then patched.
#include <gtest/gtest.h>

#include <openvdb/io/Stream.h>

#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "InputRefusals.h"
#include "MeasuredRun.h"
#include "brickstore/format/Errors.h"
#include "brickstore/read/VdbStore.h"
#include "support/TestSupport.h"
#include "support/VdbGrids.h"

namespace voxbrick {
namespace {

using test::ScratchDir;

constexpr double kMaxRefusalMB = 400;  // an idle voxbrick is about 100 MB resident
constexpr double kMaxRefusalSeconds = 5;

/// The offset of the first occurrence of `text` in `bytes` (which must hold it).
size_t offsetOf(const std::vector<char>& bytes, const std::string& text) {
  const auto it = std::search(bytes.begin(), bytes.end(), text.begin(), text.end());
  EXPECT_NE(it, bytes.end()) << "no '" << text << "' in the file";
  return size_t(it - bytes.begin());
}

uint32_t u32At(const std::vector<char>& bytes, size_t at) {
  uint32_t v;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

/// A damaged copy of `bytes`: four bytes FF FF FF FF at `at`.
std::filesystem::path patched(const ScratchDir& dir, const std::vector<char>& bytes, size_t at) {
  std::vector<char> copy = bytes;
  std::memset(copy.data() + at, 0xFF, 4);
  const auto file = dir / ("at" + std::to_string(at) + ".vdb");
  test::writeFile(file, copy.data(), copy.size());
  return file;
}

std::function<void()> opening(const std::filesystem::path& file) {
  return [file] { store::VdbStore::open(file); };
}

/// One float grid named "density", written by io::File: header 57 bytes, no file metadata, one grid whose name
/// length is at byte 65, type name length at 76 and metadata count at 128.
std::vector<char> densityFile(const ScratchDir& dir) {
  test::writeVdb(dir / "good.vdb", {test::denseGrid("density")});
  std::vector<char> bytes = test::readFile(dir / "good.vdb");
  EXPECT_EQ(u32At(bytes, 57), 0u);   // file metadata count
  EXPECT_EQ(u32At(bytes, 61), 1u);   // grid count
  EXPECT_EQ(u32At(bytes, 65), 7u);   // "density"
  EXPECT_EQ(u32At(bytes, 76), 16u);  // "Tree_float_5_4_3"
  EXPECT_GT(u32At(bytes, 128), 4u);  // the grid's metadata entries
  return bytes;
}

TEST(VdbRefusals, HeaderFieldsClaimingMoreThanTheFileAreRefusedByName) {
  ScratchDir dir;
  const std::vector<char> bytes = densityFile(dir);
  struct Case {
    size_t at;
    std::vector<std::string> words;
  };
  const size_t delayed = offsetOf(bytes, "__delayedload") + 13;  // then the value size, then the leaf count
  const size_t compression = offsetOf(bytes, "file_compression") + 16 + 4 + 6;  // then the string's size
  const size_t vec3i = offsetOf(bytes, "vec3i") + 5;                            // then the value size (12)
  const size_t transform = offsetOf(bytes, "UniformScaleMap") - 4;
  const std::vector<Case> cases = {
      {0, {"no VDB magic number"}},
      {57, {"file metadata count 4294967295", "exceeds"}},
      {61, {"grid count -1"}},
      {65, {"grid 0 name length 4294967295", "exceeds", "bytes left in the file"}},
      {66, {"grid 0 name length", "exceeds"}},
      {76, {"grid 'density' type name length 4294967295", "exceeds"}},
      {96, {"grid 'density' instance parent name length"}},
      {116, {"grid 'density' end position 4294967295", "lies past"}},
      {124, {"grid 'density' compression flags 4294967295"}},
      {128, {"grid 'density' metadata count 4294967295", "exceeds"}},
      {delayed, {"'file_delayed_load' size 4294967295", "exceeds"}},
      {delayed + 4, {"'file_delayed_load' leaf count 4294967295", "exceeds"}},
      {delayed + 8, {"'file_delayed_load' mask compressed size", "exceeds"}},
      {compression, {"'file_compression' value size 4294967295", "exceeds"}},
      {vec3i, {"(vec3i) value size 4294967295, expected 12"}},
      {transform, {"grid 'density' transform type name length 4294967295", "exceeds"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE("FF FF FF FF at byte " + std::to_string(c.at));
    const auto file = patched(dir, bytes, c.at);
    std::vector<std::string> words = c.words;
    words.push_back(file.string() + ": not a readable OpenVDB file");
    test::expectRefused(opening(file), words);
  }
  EXPECT_NO_THROW(store::VdbStore::open(dir / "good.vdb"));
}

TEST(VdbRefusals, AFileFormatVersionFromTheFutureIsRefused) {
  // The ingest fuzzer's find: version 0x80000000 was read as if it were this OpenVDB's own format.
  ScratchDir dir;
  std::vector<char> bytes = densityFile(dir);
  const uint32_t version = 0x80000000u;
  std::memcpy(bytes.data() + 8, &version, 4);
  test::writeFile(dir / "future.vdb", bytes.data(), bytes.size());
  test::expectRefused(opening(dir / "future.vdb"), {(dir / "future.vdb").string() + ": not a readable OpenVDB file",
                                                    "file format version 2147483648 is newer than"});
}

TEST(VdbRefusals, RefusingADamagedHeaderCostsLittleMemoryAndTime) {
  ScratchDir dir;
  const std::vector<char> bytes = densityFile(dir);
  const size_t delayed = offsetOf(bytes, "__delayedload") + 13 + 4;
  for (size_t at : {size_t(66), size_t(76), size_t(128), delayed}) {
    SCOPED_TRACE("FF FF FF FF at byte " + std::to_string(at));
    const auto run = test::runVoxbrickMeasured({"info", patched(dir, bytes, at).string()});
    EXPECT_EQ(run.exitCode, 1);
    EXPECT_LT(run.peakMB, kMaxRefusalMB);
    EXPECT_LT(run.seconds, kMaxRefusalSeconds);
  }
}

TEST(VdbRefusals, AStreamWithoutGridOffsetsAndSeveralGridsStillOpens) {
  ScratchDir dir;
  {
    std::ofstream out(dir / "stream.vdb", std::ios::binary);
    openvdb::io::Stream(out).write({test::sparseGrid("first"), test::denseGrid("second")});
  }
  test::writeVdb(dir / "file.vdb", {test::sparseGrid("first"), test::denseGrid("second")});
  for (const char* name : {"stream.vdb", "file.vdb"}) {
    SCOPED_TRACE(name);
    store::StoreOpenOptions options;
    options.gridName = "second";
    EXPECT_EQ(store::VdbStore::open(dir / name, options)->meta().dims.x, 70);
  }
}

}  // namespace
}  // namespace voxbrick
