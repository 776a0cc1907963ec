// OME-Zarr input that must be refused, each with the reason and the file or chunk it is about: Zarr v3, unknown
// compressors, filters and dtypes, metadata that disagrees with itself, sizes beyond the limits (refused before
// anything is allocated), corrupt and truncated chunks.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>

#include "brickstore/format/Errors.h"
#include "brickstore/read/BrickStore.h"
#include "brickstore/read/ZarrStore.h"
#include "support/TestSupport.h"
#include "support/ZarrFixtures.h"

namespace voxbrick::store {
namespace {

using nlohmann::json;
using test::ScratchDir;

/// Opening `zarr` throws an error of type E whose message holds every one of `parts`.
template <typename E>
void expectRefused(const std::filesystem::path& zarr, const std::vector<std::string>& parts) {
  try {
    ZarrStore::open(zarr, {"", 8});
    ADD_FAILURE() << zarr << " opened; expected an error with " << parts.front();
  } catch (const E& e) {
    for (const std::string& part : parts) EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong error type: " << e.what();
  }
}

class ZarrRefusals : public ::testing::Test {
 protected:
  void SetUp() override {
    zarr = test::writeZarr(dir / "v.ome.zarr", json::parse(R"({"levels": 2, "chunks": [16, 16, 16],
        "compressor": {"id": "blosc", "cname": "lz4", "shuffle": 1}})"));
  }
  /// Edits level `level`'s .zarray with `edit`.
  void editArray(const std::string& level, const std::function<void(json&)>& edit) {
    json a = test::readJsonFile(zarr / level / ".zarray");
    edit(a);
    test::writeJsonFile(zarr / level / ".zarray", a);
  }
  void editAttrs(const std::function<void(json&)>& edit) {
    json a = test::readJsonFile(zarr / ".zattrs");
    edit(a);
    test::writeJsonFile(zarr / ".zattrs", a);
  }
  ScratchDir dir;
  std::filesystem::path zarr;
};

TEST_F(ZarrRefusals, ZarrV3ByName) {
  test::writeFile(zarr / "zarr.json", std::string(R"({"zarr_format": 3, "node_type": "group"})"));
  expectRefused<InputError>(zarr, {"zarr.json", "Zarr v3", "not read"});
}

TEST_F(ZarrRefusals, UnknownCompressorFilterAndBloscCodec) {
  editArray("0", [](json& a) { a["compressor"] = {{"id", "lzma"}}; });
  expectRefused<InputError>(zarr, {"0/.zarray", "'compressor'", "lzma"});
  editArray("0", [](json& a) { a["compressor"] = {{"id", "blosc"}, {"cname", "snappy"}, {"shuffle", 1}}; });
  expectRefused<InputError>(zarr, {"0/.zarray", "snappy"});
  editArray("0", [](json& a) {
    a["compressor"] = nullptr;
    a["filters"] = json::array({{{"id", "delta"}, {"dtype", "<u2"}}});
  });
  expectRefused<InputError>(zarr, {"0/.zarray", "'filters'", "delta"});
}

TEST_F(ZarrRefusals, DtypesThatAreNotScalarNumbers) {
  for (const char* dtype : {"<i8", "<u8", "|b1", "<c8", "<M8[s]"}) {
    editArray("0", [&](json& a) { a["dtype"] = dtype; });
    expectRefused<InputError>(zarr, {"0/.zarray", "'dtype'", dtype});
  }
}

TEST_F(ZarrRefusals, MetadataThatDisagreesWithItself) {
  editArray("0", [](json& a) { a["chunks"] = {16, 16}; });
  expectRefused<InputError>(zarr, {"0/.zarray", "'chunks' has 2 axes, 'shape' has 3"});
  editArray("0", [](json& a) {
    a["chunks"] = {16, 16, 16};
    a["shape"] = {1, 40, 36, 44};
  });
  expectRefused<InputError>(zarr, {"0/.zarray", "'shape' has 4 axes"});
  editArray("0", [](json& a) { a["shape"] = {40, 36, 44}; });
  editArray("1", [](json& a) { a["shape"] = {40, 40, 44}; });
  expectRefused<InputError>(zarr, {".zattrs", "larger than the level before", "pyramid levels must shrink"});
  editArray("1", [](json& a) { a["shape"] = {40, 36, 44}; });
  expectRefused<InputError>(zarr, {".zattrs", "same shape as the level before"});
  editArray("1", [](json& a) { a["shape"] = {20, 18, 22}; });
  editArray("0", [](json& a) { a["order"] = "X"; });
  expectRefused<InputError>(zarr, {"0/.zarray", "'order'"});
  editArray("0", [](json& a) {
    a["order"] = "C";
    a["dimension_separator"] = "-";
  });
  expectRefused<InputError>(zarr, {"0/.zarray", "'dimension_separator'"});
  editArray("0", [](json& a) { a.erase("dimension_separator"); });
  editAttrs([](json& a) { a["multiscales"][0]["axes"] = json::array({"x", "y", "z"}); });
  expectRefused<InputError>(zarr, {".zattrs", "must end with z, y, x"});
  editAttrs([](json& a) { a["multiscales"][0]["axes"] = json::array({"z", "y", "x"}); });
  editAttrs([](json& a) { a["multiscales"][0]["datasets"] = json::array(); });
  expectRefused<InputError>(zarr, {".zattrs", "'datasets' is missing or empty"});
  editAttrs([](json& a) { a["multiscales"][0]["datasets"] = json::array({{{"path", "../etc"}}}); });
  expectRefused<InputError>(zarr, {".zattrs", "not a path inside the group"});
  test::writeFile(zarr / ".zattrs", std::string("{not json"));
  expectRefused<InputError>(zarr, {".zattrs", "not JSON"});
}

TEST_F(ZarrRefusals, SizesBeyondTheLimitsBeforeAllocating) {
  // 2^40 voxels with chunks of 2^30 bytes and more: refused from the metadata, nothing sized from it.
  editArray("0", [](json& a) { a["shape"] = {int64_t{1} << 30, int64_t{1} << 30, 4}; });
  editArray("1", [](json& a) { a["shape"] = {int64_t{1} << 29, int64_t{1} << 29, 2}; });
  expectRefused<InputError>(zarr, {"0/.zarray", "more than 2^24"});
  editArray("0", [](json& a) {
    a["shape"] = {40, 36, 44};
    a["chunks"] = {2048, 2048, 2048};
  });
  expectRefused<InputError>(zarr, {"0/.zarray", "larger than 1 GiB"});
  editArray("0", [](json& a) { a["chunks"] = {16, 0, 16}; });
  expectRefused<InputError>(zarr, {"0/.zarray", "'chunks'", "not an integer in [1, 2^30]"});
  // 2^50 voxels in chunks of 512 MiB: within the chunk limits, refused for its 2^41 bricks.
  editArray("0", [](json& a) {
    a["shape"] = {int64_t{1} << 20, int64_t{1} << 20, 1024};
    a["chunks"] = {512, 512, 1024};
  });
  editArray("1", [](json& a) {
    a["shape"] = {int64_t{1} << 19, int64_t{1} << 19, 512};
    a["chunks"] = {512, 512, 512};
  });
  expectRefused<InputError>(zarr, {"0/.zarray", "bricks of 8 makes", "more than 2^26"});
  editArray("1", [](json& a) {
    a["shape"] = {20, 18, 22};
    a["chunks"] = {16, 16, 16};
  });
  editArray("0", [](json& a) {
    a["chunks"] = {16, 16, 16};
    a["shape"] = {40, int64_t{1} << 31, 44};
  });
  expectRefused<InputError>(zarr, {"0/.zarray", "'shape'"});
}

TEST_F(ZarrRefusals, CorruptAndTruncatedChunksNameTheChunk) {
  const auto chunk = zarr / "0" / "1.1.1";
  ASSERT_TRUE(std::filesystem::exists(chunk));
  std::vector<char> bytes = test::readFile(chunk);
  // Truncated: half the blosc frame.
  test::writeFile(chunk, bytes.data(), bytes.size() / 2);
  expectRefused<CorruptStoreError>(zarr, {"0/1.1.1", "chunk 1,1,1 of level 0", "truncated"});
  // Corrupt: the right size, garbage after the header.
  std::vector<char> garbage = bytes;
  for (size_t i = 16; i < garbage.size(); ++i) garbage[i] = char(i * 37);
  test::writeFile(chunk, garbage.data(), garbage.size());
  expectRefused<CorruptStoreError>(zarr, {"0/1.1.1", "chunk 1,1,1 of level 0"});
  // An uncompressed chunk of the wrong size.
  editArray("0", [](json& a) { a["compressor"] = nullptr; });
  // Every chunk of level 0 is still blosc: the first one read is named.
  expectRefused<CorruptStoreError>(zarr, {"(chunk ", "of level 0)", "an uncompressed chunk has 8192", "truncated"});
}

TEST_F(ZarrRefusals, AChunkDamagedAfterOpenIsNamedWhenABrickNeedsIt) {
  // A cache of one decoded chunk: reading the bricks again decodes the chunks again, the damaged one included.
  const auto live = ZarrStore::open(zarr, {"", 8}, 1);
  const std::vector<char> bytes = test::readFile(zarr / "0" / "1.1.1");
  test::writeFile(zarr / "0" / "1.1.1", bytes.data(), bytes.size() / 2);
  std::vector<char> samples(live->brickBytes());
  std::string error;
  const Vec3i nb = live->level(0).bricks;
  for (uint32_t k = 0; k < nb.z && error.empty(); ++k)
    for (uint32_t j = 0; j < nb.y && error.empty(); ++j)
      for (uint32_t i = 0; i < nb.x && error.empty(); ++i) {
        try {
          live->readBrick({0, i, j, k}, samples.data());
        } catch (const CorruptStoreError& e) {
          error = e.what();
        }
      }
  EXPECT_NE(error.find("0/1.1.1 (chunk 1,1,1 of level 0)"), std::string::npos) << error;
}

TEST_F(ZarrRefusals, CorruptZlibAndZstdChunks) {
  for (const char* id : {"zlib", "gzip", "zstd"}) {
    ScratchDir d;
    const auto z = test::writeZarr(d / "z.ome.zarr", json::parse(std::string(R"({"compressor": {"id": ")") + id +
                                                                 R"("}, "chunks": [16, 16, 16]})"));
    std::vector<char> bytes = test::readFile(z / "0" / "1.1.1");
    test::writeFile(z / "0" / "1.1.1", bytes.data(), bytes.size() - 9);
    expectRefused<CorruptStoreError>(z, {"1.1.1", id});
  }
}

}  // namespace
}  // namespace voxbrick::store
