// An OME-Zarr read live (ZarrStore) against the store `voxbrick prep` makes of it, for every compressor, order,
// separator and dtype python3-zarr writes: metadata, records, octree and every brick of every level; its own pyramid
// levels used as LOD levels; missing chunks; spacing and position; time and channel.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "brickstore/format/Errors.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/ZarrStore.h"
#include "support/LiveStores.h"
#include "support/TestSupport.h"
#include "support/ZarrFixtures.h"

namespace voxbrick::store {
namespace {

using nlohmann::json;
using test::brickKeys;
using test::expectSameBricks;
using test::prepOf;
using test::ScratchDir;

struct ZarrCase {
  const char* name;
  const char* spec;  // zarr_fixture.py's JSON, less "out"
  int brick;
  ValueType type;
};

std::string zarrCaseName(const ::testing::TestParamInfo<ZarrCase>& info) { return info.param.name; }

/// How many samples of the level-0 bricks of `cache`'s store (borders included: the voxel clamped to the volume)
/// differ from `voxels`, level 0 as the fixture wrote it (float64, x fastest), converted to the store's type; the
/// first few are reported.
int64_t samplesUnlikeTheArray(BrickCache& cache, const std::vector<double>& voxels, const std::string& what) {
  const BrickStore& s = *cache.store();
  const Vec3i d = s.meta().dims;
  EXPECT_EQ(voxels.size(), size_t(d.volume())) << what;
  if (voxels.size() != size_t(d.volume())) return d.volume();
  const int64_t B = s.brickSize(), E = s.brickEdge();
  int64_t differ = 0;
  for (const BrickKey& key : brickKeys(s, 0)) {
    const BrickHandle brick = cache.get(key);
    dispatchType(s.type(), [&](auto tag) {
      using T = decltype(tag);
      const T* samples = static_cast<const T*>(brick->data());
      for (int64_t c = 0; c < E; ++c)
        for (int64_t b = 0; b < E; ++b)
          for (int64_t a = 0; a < E; ++a) {
            const int64_t x = std::clamp<int64_t>(int64_t(key.i) * B + a - 1, 0, d.x - 1);
            const int64_t y = std::clamp<int64_t>(int64_t(key.j) * B + b - 1, 0, d.y - 1);
            const int64_t z = std::clamp<int64_t>(int64_t(key.k) * B + c - 1, 0, d.z - 1);
            const double written = voxels[size_t(x + d.x * (y + d.y * z))];
            const T got = samples[a + E * (b + E * c)];
            if (got != static_cast<T>(written) && ++differ <= 3)
              ADD_FAILURE() << what << ": voxel " << x << "," << y << "," << z << " is " << double(got)
                            << ", the array holds " << written;
          }
    });
  }
  return differ;
}

class ZarrMatchesPrep : public ::testing::TestWithParam<ZarrCase> {
 protected:
  void SetUp() override {
    json spec = json::parse(GetParam().spec);
    spec["dump"] = (dir / "level0.f8").string();
    zarr = test::writeZarr(dir / "v.ome.zarr", spec);
    written = test::readZarrDump(dir / "level0.f8");
    live = ZarrStore::open(zarr, {"", GetParam().brick});
    prepped = prepOf(zarr, dir / "prepped", GetParam().brick);
  }

  ScratchDir dir;
  std::filesystem::path zarr;
  std::vector<double> written;  // level 0 as the fixture wrote it
  std::shared_ptr<const ZarrStore> live;
  std::shared_ptr<const BrickStore> prepped;
};

TEST_P(ZarrMatchesPrep, MetadataAndRecords) {
  const StoreMeta& p = prepped->meta();
  const StoreMeta& l = live->meta();
  EXPECT_EQ(live->backing(), StoreBacking::ZarrDirectory);
  EXPECT_EQ(l.type, GetParam().type);
  EXPECT_EQ(l.dims, (Vec3i{44, 36, 40}));
  EXPECT_EQ(l.dims, p.dims);
  EXPECT_EQ(l.spacing, p.spacing);
  EXPECT_EQ(l.orientation, p.orientation);
  EXPECT_EQ(l.type, p.type);
  EXPECT_EQ(l.background, p.background);
  test::expectSameStats(l, p);
  ASSERT_EQ(l.levels.size(), p.levels.size());
  for (int m = 0; m < live->levelCount(); ++m) {
    EXPECT_EQ(l.levels[size_t(m)].dims, p.levels[size_t(m)].dims);
    if (!live->ownLevels()[size_t(m)]) continue;
    // Own levels were read at open: exactly prep's records.
    EXPECT_EQ(l.levels[size_t(m)].bricksStored, p.levels[size_t(m)].bricksStored) << m;
    test::expectSameRecords(*live, *prepped, m);
  }
  const MinMaxOctree& a = live->octree();
  const MinMaxOctree& b = prepped->octree();
  ASSERT_EQ(a.depth(), b.depth());
  const Vec3i n = a.nodesAt(0);
  for (int64_t k = 0; k < n.z; ++k)
    for (int64_t j = 0; j < n.y; ++j)
      for (int64_t i = 0; i < n.x; ++i) {
        EXPECT_EQ(a.range(0, i, j, k).min, b.range(0, i, j, k).min);
        EXPECT_EQ(a.range(0, i, j, k).max, b.range(0, i, j, k).max);
      }
}

TEST_P(ZarrMatchesPrep, EveryBrickOfEveryLevel) {
  BrickCache liveCache(live, size_t(64) << 20, 2);
  BrickCache preppedCache(prepped, size_t(64) << 20, 0);
  int64_t compared = 0;
  for (int level = 0; level < live->levelCount(); ++level) {
    const std::vector<BrickKey> keys = brickKeys(*live, level);
    compared += expectSameBricks(liveCache, preppedCache, keys);
    for (const BrickKey& key : keys)
      if (prepped->isStored(key)) {
        EXPECT_TRUE(live->isStored(key)) << toString(key);
      }
  }
  EXPECT_GT(compared, 30);
  // And level 0 is the array the fixture wrote, voxel for voxel: live and prep read the chunks through the same
  // decoder, so a misread (byte order, shuffle, memory order, a dtype's conversion) would make them agree on wrong
  // values.
  EXPECT_EQ(samplesUnlikeTheArray(liveCache, written, "live"), 0);
  EXPECT_EQ(samplesUnlikeTheArray(preppedCache, written, "prep"), 0);
}

// Every compressor, order and separator, and the dtypes: u8, u16, i16, f32 kept; int8 widened; the rest f32. Three
// levels written, so with B = 8 store levels 0-2 are the file's and level 3 is averaged; RawU16 has four, all used.

INSTANTIATE_TEST_SUITE_P(
    Codecs, ZarrMatchesPrep,
    ::testing::Values(
        ZarrCase{"RawU16", R"({"levels": 4, "chunks": [16, 12, 16], "compressor": {"id": "none"}})", 8, ValueType::U16},
        ZarrCase{"ZlibU8", R"({"levels": 3, "chunks": [16, 12, 16], "dtype": "|u1", "compressor": {"id": "zlib"}})", 8,
                 ValueType::U8},
        ZarrCase{"GzipI16F", R"({"levels": 3, "chunks": [16, 12, 16], "dtype": "<i2", "order": "F",
                             "compressor": {"id": "gzip"}})",
                 8, ValueType::I16},
        ZarrCase{"ZstdF32Slash", R"({"levels": 3, "chunks": [16, 12, 16], "dtype": "<f4", "separator": "/",
                                 "compressor": {"id": "zstd"}})",
                 8, ValueType::F32},
        ZarrCase{"BloscLz4ShuffleU16", R"({"levels": 3, "chunks": [16, 12, 16],
                                       "compressor": {"id": "blosc", "cname": "lz4", "shuffle": 1}})",
                 8, ValueType::U16},
        ZarrCase{"BloscZstdBitshuffleF32F", R"({"levels": 3, "chunks": [16, 12, 16], "dtype": "<f4", "order": "F",
                                            "compressor": {"id": "blosc", "cname": "zstd", "shuffle": 2}})",
                 8, ValueType::F32},
        ZarrCase{"BloscZlibNoShuffleBigEndianU16", R"({"levels": 3, "chunks": [16, 12, 16], "dtype": ">u2",
                 "compressor": {"id": "blosc", "cname": "zlib", "shuffle": 0}})",
                 8, ValueType::U16},
        ZarrCase{"BlosclzI8", R"({"levels": 3, "chunks": [16, 12, 16], "dtype": "|i1",
                             "compressor": {"id": "blosc", "cname": "blosclz", "shuffle": 1}})",
                 8, ValueType::I16},
        ZarrCase{"ZstdI32", R"({"levels": 3, "chunks": [16, 12, 16], "dtype": "<i4", "compressor": {"id": "zstd"}})",
                 16, ValueType::F32},
        ZarrCase{"BloscLz4F64", R"({"levels": 3, "chunks": [16, 12, 16], "dtype": "<f8",
                               "compressor": {"id": "blosc", "cname": "lz4", "shuffle": 1}})",
                 16, ValueType::F32}),
    zarrCaseName);

TEST(ZarrStore, OwnLevelsAreTheFilesAndMissingChunksAreNeverRead) {
  ScratchDir dir;
  const auto zarr = test::writeZarr(dir / "v.ome.zarr", json::parse(R"({"levels": 3, "chunks": [16, 12, 16],
      "compressor": {"id": "blosc", "cname": "lz4", "shuffle": 1}})"));
  const auto live = ZarrStore::open(zarr, {"", 8});
  ASSERT_EQ(live->levelCount(), 4);
  EXPECT_EQ(live->ownLevels(), (std::vector<bool>{true, true, true, false}));
  EXPECT_EQ(live->openStats().ownLevels, 3);
  EXPECT_NE(live->meta().source.find("averaged"), std::string::npos) << live->meta().source;
  // The fixture's level 1 is level 0 every other voxel (not its average): the store's level 1 must be that.
  BrickCache cache(live, size_t(64) << 20, 0);
  const int64_t E = live->brickEdge();
  int checked = 0;
  for (uint32_t k = 0; k < live->level(1).bricks.z; ++k) {
    const BrickKey key{1, 1, 1, k};
    const auto* s = static_cast<const uint16_t*>(cache.get(key)->data());
    for (int64_t c = 1; c <= 8; ++c)
      for (int64_t a = 1; a <= 8; ++a) {
        const Vec3i v1{8 + a - 1, 8 + 3, int64_t(k) * 8 + c - 1};
        if (v1.z >= live->level(1).dims.z) continue;
        uint16_t v0 = 0;
        live->chunks().readRegion(0, {2 * v1.x, 2 * v1.y, 2 * v1.z}, {2 * v1.x, 2 * v1.y, 2 * v1.z}, &v0);
        ASSERT_EQ(s[a + E * (4 + E * c)], v0) << "level 1 voxel " << v1.x << "," << v1.y << "," << v1.z;
        checked += v0 != 0;
      }
  }
  EXPECT_GT(checked, 10);
  // The ball leaves corner chunks unwritten: bricks over them alone are known empty without reading.
  const ZarrOpenStats& o = live->openStats();
  EXPECT_LT(o.chunksPresent, o.chunksTotal);
  EXPECT_LT(o.bricksScanned,
            live->level(0).bricksTotal() + live->level(1).bricksTotal() + live->level(2).bricksTotal());
  EXPECT_FALSE(live->isStored({0, 0, 0, 0}));
  EXPECT_TRUE(live->meta().levels[0].bricksStored < live->level(0).bricksTotal());
}

TEST(ZarrStore, PyramidThatDoesNotHalveIsAveraged) {
  ScratchDir dir;
  const auto zarr = test::writeZarr(dir / "v.ome.zarr", json::parse(R"({"levels": 3, "chunks": [16, 16, 16]})"));
  // Level 1 rewritten one voxel short along x: no longer the halving prep's pyramid has.
  json a = test::readJsonFile(zarr / "1" / ".zarray");
  a["shape"][2] = a["shape"][2].get<int>() - 1;
  test::writeJsonFile(zarr / "1" / ".zarray", a);
  const auto live = ZarrStore::open(zarr, {"", 8});
  EXPECT_EQ(live->openStats().ownLevels, 1);
  const auto prepped = prepOf(zarr, dir / "prepped", 8);
  BrickCache liveCache(live, size_t(64) << 20, 0), preppedCache(prepped, size_t(64) << 20, 0);
  for (int level = 0; level < live->levelCount(); ++level) {
    const std::vector<BrickKey> keys = brickKeys(*live, level);
    EXPECT_EQ(expectSameBricks(liveCache, preppedCache, keys), int64_t(keys.size())) << "level " << level;
  }
}

TEST(ZarrStore, CoarseBricksWithoutACache) {
  // readBrick of an averaged level without a fetch builds the finer levels through a temporary cache: same bytes.
  ScratchDir dir;
  const auto zarr = test::writeZarr(dir / "v.ome.zarr", json::parse(R"({"levels": 2, "chunks": [16, 12, 16],
      "dtype": "<f4", "compressor": {"id": "zstd"}})"));
  const auto live = ZarrStore::open(zarr, {"", 8});
  const auto prepped = prepOf(zarr, dir / "prepped", 8);
  const int top = live->levelCount() - 1;
  ASSERT_FALSE(live->ownLevels()[size_t(top)]) << "the coarsest level must be averaged";
  BrickCache preppedCache(prepped, size_t(64) << 20, 0);
  for (const BrickKey& key : brickKeys(*live, top)) {
    std::vector<char> samples(live->brickBytes());
    live->readBrick(key, samples.data());
    EXPECT_EQ(std::memcmp(samples.data(), preppedCache.get(key)->data(), samples.size()), 0) << toString(key);
  }
}

TEST(ZarrStore, SpacingPositionAndFillValue) {
  ScratchDir dir;
  const auto zarr = test::writeZarr(dir / "v.ome.zarr", json::parse(R"({"levels": 2, "scale": [2.5, 1.0, 0.5],
      "translation": [10.0, -4.0, 3.0], "fill": 0, "compressor": {"id": "zstd"}})"));
  const auto live = ZarrStore::open(zarr, {"", 8});
  EXPECT_EQ(live->meta().spacing, (Vec3d{0.5, 1.0, 2.5}));
  EXPECT_EQ(live->meta().orientation.origin, (Orientation::Vec{3.0, -4.0, 10.0}));
  // A missing chunk reads as the fill value: rewrite the fill value and remove a chunk by hand.
  json a = test::readJsonFile(zarr / "0" / ".zarray");
  a["fill_value"] = 7;
  test::writeJsonFile(zarr / "0" / ".zarray", a);
  std::filesystem::remove(zarr / "0" / "1.1.1");
  const auto filled = ZarrStore::open(zarr, {"", 8});
  EXPECT_EQ(filled->meta().background, 7.0);
  uint16_t v = 0;
  filled->chunks().readRegion(0, {20, 20, 20}, {20, 20, 20}, &v);
  EXPECT_EQ(v, 7);
}

TEST(ZarrStore, TimeAndChannelPickOneVolume) {
  ScratchDir dir;
  const auto zarr = test::writeZarr(dir / "v.ome.zarr", json::parse(R"({"levels": 2, "axes": "tczyx", "t": 2,
      "c": 3, "compressor": {"id": "blosc", "cname": "lz4", "shuffle": 1}})"));
  const auto first = ZarrStore::open(zarr, {"", 8, 0, 0});
  const auto last = ZarrStore::open(zarr, {"", 8, 1, 2});
  // Inside the ball the fixture adds 100 per time point and 30 per channel.
  uint16_t a = 0, b = 0;
  first->chunks().readRegion(0, {24, 16, 22}, {24, 16, 22}, &a);
  last->chunks().readRegion(0, {24, 16, 22}, {24, 16, 22}, &b);
  ASSERT_GT(a, 0);
  EXPECT_EQ(int(b) - int(a), 160);
  EXPECT_EQ(last->meta().valueMax - first->meta().valueMax, 160);
  EXPECT_NE(last->meta().source.find("t=1 c=2"), std::string::npos) << last->meta().source;
  // prep of the same selection equals it brick for brick.
  SourceOptions so;
  so.time = 1;
  so.channel = 2;
  const auto prepped = prepOf(zarr, dir / "prepped", 8, so);
  BrickCache liveCache(last, size_t(64) << 20, 0), preppedCache(prepped, size_t(64) << 20, 0);
  const std::vector<BrickKey> keys = brickKeys(*last, 0);
  EXPECT_EQ(expectSameBricks(liveCache, preppedCache, keys), int64_t(keys.size()));
  EXPECT_THROW(ZarrStore::open(zarr, {"", 8, 2, 0}), InputError);
  EXPECT_THROW(ZarrStore::open(zarr, {"", 8, 0, 3}), InputError);
  // Chunks spanning several time points and channels, in F order: the same voxels.
  const auto wide = test::writeZarr(dir / "w.ome.zarr", json::parse(R"({"levels": 2, "axes": "tczyx", "t": 2,
      "c": 3, "lead_chunks": [2, 2], "order": "F", "compressor": {"id": "zstd"}})"));
  const auto wideLast = ZarrStore::open(wide, {"", 8, 1, 2});
  uint16_t c = 0;
  wideLast->chunks().readRegion(0, {24, 16, 22}, {24, 16, 22}, &c);
  EXPECT_EQ(c, b);
  EXPECT_EQ(wideLast->meta().histogram.counts, last->meta().histogram.counts);
}

TEST(ZarrStore, IsZarrDirectoryFindsMultiscalesAfterALongBlockAndNotInAnEmptyFile) {
  ScratchDir dir;
  const std::filesystem::path group = dir / "g.zarr";
  std::filesystem::create_directories(group);
  test::writeFile(group / ".zgroup", std::string(R"({"zarr_format": 2})"));
  test::writeFile(group / ".zattrs", std::string());
  EXPECT_FALSE(isZarrDirectory(group)) << "an empty .zattrs names no multiscales";
  test::writeFile(group / ".zattrs",
                  R"({"omero": {"name": ")" + std::string(300000, 'x') + R"("}, "multiscales": []})");
  EXPECT_TRUE(isZarrDirectory(group)) << "\"multiscales\" 300 kB into .zattrs";
  test::writeFile(group / ".zattrs", R"({"omero": {"name": ")" + std::string(size_t{2} << 20, 'x') + R"("}})");
  EXPECT_FALSE(isZarrDirectory(group));
}

TEST(ZarrStore, CommandsTakeTheDirectory) {
  ScratchDir dir;
  const auto zarr = test::writeZarr(dir / "v.ome.zarr", json::parse(R"({"levels": 3, "axes": "czyx", "c": 2,
      "compressor": {"id": "zstd"}})"));
  auto info = test::runVoxbrick("info " + zarr.string() + " --channel 1 --brick 8");
  EXPECT_EQ(info.exitCode, 0) << info.output;
  EXPECT_NE(info.output.find("OME-Zarr, read live"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("c=1"), std::string::npos) << info.output;
  auto prep = test::runVoxbrick("prep " + zarr.string() + " --channel 1 --brick 8 -q -o " + (dir / "p").string());
  EXPECT_EQ(prep.exitCode, 0) << prep.output;
  auto bad = test::runVoxbrick("info " + zarr.string() + " --channel 2");
  EXPECT_NE(bad.exitCode, 0);
  EXPECT_NE(bad.output.find("--channel 2 is outside the 'c' axis (2 channels)"), std::string::npos) << bad.output;
  auto notZarr = test::runVoxbrick("info " + (dir / "p").string() + " --time 1");
  EXPECT_NE(notZarr.exitCode, 0);
  EXPECT_NE(notZarr.output.find("--time and --channel apply to an OME-Zarr only"), std::string::npos) << notZarr.output;
}

}  // namespace
}  // namespace voxbrick::store
