// A .vdb read live (VdbStore) against the store `voxbrick prep` makes of the same file: metadata, records, the
// octree and every brick of every level; empty bricks known from the topology; bad files and options.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "brickstore/format/Errors.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/OpenAnyStore.h"
#include "brickstore/read/VdbStore.h"
#include "support/LiveStores.h"
#include "support/TestSupport.h"
#include "support/VdbGrids.h"

namespace voxbrick::store {
namespace {

using test::brickKeys;
using test::prepOf;
using test::ScratchDir;

struct VdbStoreCase {
  const char* name;
  bool sparse;
  int brick;
};

std::string vdbStoreCaseName(const ::testing::TestParamInfo<VdbStoreCase>& info) {
  return std::string(info.param.name) + "B" + std::to_string(info.param.brick);
}

class VdbStoreMatchesPrep : public ::testing::TestWithParam<VdbStoreCase> {
 protected:
  void SetUp() override {
    vdb = dir / (std::string(GetParam().name) + ".vdb");
    test::writeVdb(vdb, {GetParam().sparse ? test::sparseGrid() : test::denseGrid()});
    prepped = prepOf(vdb, dir / "prepped", GetParam().brick);
    live = VdbStore::open(vdb, {"", GetParam().brick});
  }

  ScratchDir dir;
  std::filesystem::path vdb;
  std::shared_ptr<const BrickStore> prepped;
  std::shared_ptr<const VdbStore> live;
};

TEST_P(VdbStoreMatchesPrep, Metadata) {
  const StoreMeta& p = prepped->meta();
  const StoreMeta& l = live->meta();
  EXPECT_EQ(live->backing(), StoreBacking::VdbFile);
  EXPECT_EQ(prepped->backing(), StoreBacking::Directory);
  EXPECT_EQ(l.dims, p.dims);
  EXPECT_EQ(l.spacing, p.spacing);
  EXPECT_EQ(l.type, ValueType::F32);
  EXPECT_EQ(l.background, p.background);
  test::expectSameStats(l, p);
  EXPECT_EQ(l.nonFiniteReplaced, p.nonFiniteReplaced);
  EXPECT_EQ(l.nonFiniteReplaced, GetParam().sparse ? 1 : 0);
  EXPECT_EQ(l.histogram.lo, p.histogram.lo);
  EXPECT_EQ(l.histogram.hi, p.histogram.hi);
  EXPECT_EQ(l.brickSize, GetParam().brick);
  EXPECT_EQ(l.source, p.source);
  EXPECT_EQ(l.bytesRaw, p.bytesRaw);
  EXPECT_EQ(l.vdbFiles, std::vector<std::string>{vdb.filename().string()});
  EXPECT_EQ(l.bytesVdb, int64_t(std::filesystem::file_size(vdb)));
  ASSERT_EQ(l.levels.size(), p.levels.size());
  ASSERT_GE(l.levels.size(), 3u);
  for (size_t k = 0; k < l.levels.size(); ++k) {
    EXPECT_EQ(l.levels[k].dims, p.levels[k].dims) << k;
    EXPECT_EQ(l.levels[k].bricks, p.levels[k].bricks) << k;
    // Level 0 is exact; coarser levels count the bricks over data, a superset of those prep found non-empty.
    if (k == 0) {
      EXPECT_EQ(l.levels[k].bricksStored, p.levels[k].bricksStored);
    } else {
      EXPECT_GE(l.levels[k].bricksStored, p.levels[k].bricksStored) << k;
    }
  }
  if (GetParam().sparse) {
    EXPECT_LT(l.levels[0].bricksStored, l.levels[0].bricksTotal() / 2) << "the sparse grid must leave bricks empty";
  } else {
    EXPECT_EQ(l.levels[0].bricksStored, l.levels[0].bricksTotal());
  }
}

TEST_P(VdbStoreMatchesPrep, RecordsAndOctree) {
  test::expectSameRecords(*live, *prepped, 0);
  const MinMaxOctree& a = live->octree();
  const MinMaxOctree& b = prepped->octree();
  ASSERT_EQ(a.depth(), b.depth());
  for (int d = 0; d <= a.depth(); ++d) {
    const Vec3i n = a.nodesAt(d);
    for (int64_t k = 0; k < n.z; ++k)
      for (int64_t j = 0; j < n.y; ++j)
        for (int64_t i = 0; i < n.x; ++i) {
          EXPECT_EQ(a.range(d, i, j, k).min, b.range(d, i, j, k).min);
          EXPECT_EQ(a.range(d, i, j, k).max, b.range(d, i, j, k).max);
        }
  }
}

TEST_P(VdbStoreMatchesPrep, EveryBrickOfEveryLevel) {
  BrickCache liveCache(live, size_t(256) << 20, 2);
  BrickCache preppedCache(prepped, size_t(256) << 20, 0);
  int64_t compared = 0, coarseWithData = 0;
  for (int level = 0; level < live->levelCount(); ++level) {
    const std::vector<BrickKey> keys = brickKeys(*live, level);
    // Coarse bricks built on the prefetch workers and on this thread at once share the finer bricks.
    liveCache.prefetch(keys);
    for (const BrickKey& key : keys) {
      const BrickHandle a = liveCache.get(key), b = preppedCache.get(key);
      ASSERT_EQ(a->bytes(), b->bytes());
      ASSERT_EQ(std::memcmp(a->data(), b->data(), a->bytes()), 0) << toString(key) << " differs from prep's";
      ++compared;
      if (level == 0) continue;
      // A coarse record bounds the brick and is stored wherever prep's is.
      const BrickRecord& r = live->record(key);
      const BrickRecord& p = prepped->record(key);
      if (prepped->isStored(key)) {
        EXPECT_TRUE(live->isStored(key)) << toString(key);
      }
      EXPECT_LE(r.min, p.min) << toString(key);
      EXPECT_GE(r.max, p.max) << toString(key);
      coarseWithData += !b->isEmpty();
    }
  }
  EXPECT_GT(coarseWithData, 0);
  std::cout << compared << " bricks equal over " << live->levelCount() << " levels\n";
}

TEST_P(VdbStoreMatchesPrep, ThroughTheCacheEachBrickIsBuiltOnce) {
  BrickCache cache(live, size_t(256) << 20, 0);
  const int top = live->levelCount() - 1;
  // Asking for the coarsest level first builds everything below it through the cache.
  const Vec3i nbTop = live->level(top).bricks;
  for (uint32_t k = 0; k < nbTop.z; ++k)
    for (uint32_t j = 0; j < nbTop.y; ++j)
      for (uint32_t i = 0; i < nbTop.x; ++i) cache.get({uint32_t(top), i, j, k});
  for (int level = 0; level <= top; ++level) {
    int64_t stored = 0;
    for (const BrickKey& key : brickKeys(*live, level)) stored += live->isStored(key);
    EXPECT_LE(live->bricksBuilt(level), stored) << "level " << level;
    EXPECT_GT(live->bricksBuilt(level), 0) << "level " << level;
  }
  EXPECT_EQ(cache.stats().evictions, 0u);
}

TEST_P(VdbStoreMatchesPrep, CoarseBricksWithoutACache) {
  // readBrick without a fetch builds the finer levels through a temporary cache: same bytes, just slower.
  const int top = live->levelCount() - 1;
  BrickCache preppedCache(prepped, size_t(64) << 20, 0);
  std::vector<char> samples(live->brickBytes());
  const BrickKey key{uint32_t(top), 0, 0, 0};
  live->readBrick(key, samples.data());
  EXPECT_EQ(std::memcmp(samples.data(), preppedCache.get(key)->data(), samples.size()), 0);
}

INSTANTIATE_TEST_SUITE_P(Grids, VdbStoreMatchesPrep,
                         ::testing::Values(VdbStoreCase{"Sparse", true, 16}, VdbStoreCase{"Sparse", true, 8},
                                           VdbStoreCase{"Dense", false, 16}, VdbStoreCase{"Dense", false, 32}),
                         vdbStoreCaseName);

TEST(VdbStore, EmptyBricksAreKnownFromTheTopologyAndNeverRead) {
  ScratchDir dir;
  const openvdb::FloatGrid::Ptr grid = test::sparseGrid();
  test::writeVdb(dir / "sparse.vdb", {grid});
  constexpr int B = 16;
  const auto live = VdbStore::open(dir / "sparse.vdb", {"", B});
  const Vec3i nb = live->level(0).bricks;

  // Independently of the store: the bricks whose voxels (border included) meet a leaf node or the one tile.
  const openvdb::Coord origin = grid->evalActiveVoxelBoundingBox().min();
  std::vector<openvdb::CoordBBox> nodes;
  for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) nodes.push_back(leaf->getNodeBoundingBox());
  nodes.push_back(openvdb::CoordBBox(openvdb::Coord(16, 0, 32), openvdb::Coord(23, 7, 39)));
  int64_t near = 0;
  for (int64_t k = 0; k < nb.z; ++k)
    for (int64_t j = 0; j < nb.y; ++j)
      for (int64_t i = 0; i < nb.x; ++i) {
        const openvdb::CoordBBox reads(origin + openvdb::Coord(int(i * B - 1), int(j * B - 1), int(k * B - 1)),
                                       origin + openvdb::Coord(int(i * B + B), int(j * B + B), int(k * B + B)));
        bool hit = false;
        for (const openvdb::CoordBBox& node : nodes) hit = hit || reads.hasOverlap(node);
        near += hit;
      }
  EXPECT_EQ(live->openStats().bricksScanned, near);
  EXPECT_EQ(live->openStats().tiles, 1);
  EXPECT_GT(live->openStats().leafNodes, 0);
  EXPECT_LT(near, nb.volume() / 2) << "most bricks must be known empty without a read";

  // Reading every level-0 brick through the cache extracts only the stored ones; the others are the shared
  // background, never decoded.
  BrickCache cache(live, size_t(64) << 20, 0);
  int64_t stored = 0;
  for (const BrickKey& key : brickKeys(*live, 0)) {
    const BrickHandle brick = cache.get(key);
    stored += live->isStored(key);
    EXPECT_EQ(brick->isEmpty(), !live->isStored(key));
  }
  EXPECT_GT(stored, 0);
  EXPECT_EQ(live->bricksBuilt(0), stored);
  EXPECT_EQ(int64_t(cache.stats().emptyGets), nb.volume() - stored);
  EXPECT_EQ(int64_t(cache.stats().bricksDecoded), stored);
}

TEST(VdbStore, OpensByFormWithGridAndBrickOptions) {
  ScratchDir dir;
  test::writeVdb(dir / "two.vdb", {test::denseGrid("first"), test::sparseGrid("second")});
  const auto byDefault = openAnyStore(dir / "two.vdb");
  EXPECT_EQ(byDefault->backing(), StoreBacking::VdbFile);
  EXPECT_NE(byDefault->meta().source.find("'first'"), std::string::npos);
  EXPECT_EQ(byDefault->brickSize(), 32);
  const auto named = openAnyStore(dir / "two.vdb", {"second", 8});
  EXPECT_NE(named->meta().source.find("'second'"), std::string::npos);
  EXPECT_EQ(named->brickSize(), 8);
  EXPECT_EQ(named->meta().background, 0.25);

  auto prepped = prepOf(dir / "two.vdb", dir / "store", 16);
  EXPECT_EQ(openAnyStore(dir / "store")->backing(), StoreBacking::Directory);
  EXPECT_THROW(openAnyStore(dir / "store", {"second", 32}), InputError);
  EXPECT_THROW(openAnyStore(dir / "store", {"", 16}), InputError);
}

/// The message of the InputError opening `path` throws.
std::string openError(const std::filesystem::path& path, const StoreOpenOptions& options = {}) {
  try {
    VdbStore::open(path, options);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << path << " opened";
  return {};
}

TEST(VdbStore, BadFilesAndOptionsAreNamed) {
  ScratchDir dir;
  openvdb::Vec3SGrid::Ptr velocity = openvdb::Vec3SGrid::create();
  velocity->setName("velocity");
  velocity->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3s(1, 0, 0));
  test::writeVdb(dir / "grids.vdb", {velocity, test::sparseGrid()});
  test::writeVdb(dir / "vectors.vdb", {velocity});
  openvdb::FloatGrid::Ptr empty = openvdb::FloatGrid::create(1.0f);
  empty->setName("empty");
  test::writeVdb(dir / "empty.vdb", {empty});
  test::writeFile(dir / "garbage.vdb", std::string(4096, '\x5a'));
  const std::vector<char> good = test::readFile(dir / "grids.vdb");
  test::writeFile(dir / "truncated.vdb", good.data(), good.size() - 100);

  const std::string grids = (dir / "grids.vdb").string();
  EXPECT_NE(openError(dir / "grids.vdb", {"velocity", 32}).find(grids + ": grid 'velocity' is vec3s, expected a float"),
            std::string::npos);
  EXPECT_NE(openError(dir / "grids.vdb", {"pressure", 32}).find(grids + ": has no grid named 'pressure'"),
            std::string::npos);
  EXPECT_NE(openError(dir / "vectors.vdb").find("has no float grid"), std::string::npos);
  EXPECT_NE(openError(dir / "empty.vdb").find("grid 'empty' has no active voxels"), std::string::npos);
  EXPECT_NE(openError(dir / "garbage.vdb").find((dir / "garbage.vdb").string() + ": not a readable OpenVDB file"),
            std::string::npos);
  EXPECT_NE(openError(dir / "truncated.vdb").find("not a readable OpenVDB file"), std::string::npos);
  EXPECT_NE(openError(dir / "grids.vdb", {"", 12}).find("--brick 12 is not a power of two"), std::string::npos);
  EXPECT_NE(openError(dir / "grids.vdb", {"", 512}).find("--brick 512"), std::string::npos);
  EXPECT_THROW(VdbStore::open(dir / "missing.vdb"), InputError);
}

TEST(VdbStore, AHugeSparseBoundingBoxIsRefusedBeforeItsRecordsAreSized) {
  // Two active voxels 200000 apart: a few bytes of file, a bounding box of 6251^3 bricks of 32 to hold records for.
  ScratchDir dir;
  openvdb::initialize();
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
  grid->setName("density");
  grid->tree().setValue(openvdb::Coord(0, 0, 0), 1.0f);
  grid->tree().setValue(openvdb::Coord(200000, 200000, 200000), 2.0f);
  test::writeVdb(dir / "far.vdb", {grid});
  const std::string error = openError(dir / "far.vdb", {"", 32});
  EXPECT_NE(error.find((dir / "far.vdb").string() + ": the active voxels' bounding box 200001x200001x200001 in "
                                                    "bricks of 32 makes 244257831251 bricks, more than 2^26"),
            std::string::npos)
      << error;
}

TEST(VdbStore, InfoCommandDescribesAVdbAsItsPreppedStore) {
  ScratchDir dir;
  test::writeVdb(dir / "sparse.vdb", {test::sparseGrid()});
  prepOf(dir / "sparse.vdb", dir / "prepped", 16);
  const auto live = test::runVoxbrick("info " + (dir / "sparse.vdb").string() + " --brick 16 --json");
  ASSERT_EQ(live.exitCode, 0) << live.output;
  const auto store = test::runVoxbrick("info " + (dir / "prepped").string() + " --json");
  ASSERT_EQ(store.exitCode, 0) << store.output;
  const nlohmann::json a = nlohmann::json::parse(live.output), b = nlohmann::json::parse(store.output);
  EXPECT_EQ(a["backing"], "vdb-file");
  EXPECT_EQ(b["backing"], "directory");
  for (const char* key : {"dims", "spacing", "type", "background", "value_range", "histogram", "brick_size",
                          "active_voxels", "octree_depth", "empty_fraction", "source"})
    EXPECT_EQ(a[key], b[key]) << key;
  ASSERT_EQ(a["levels"].size(), b["levels"].size());
  for (size_t l = 0; l < a["levels"].size(); ++l) EXPECT_EQ(a["levels"][l]["dims"], b["levels"][l]["dims"]);
  EXPECT_GT(a["open"]["bricks_scanned"].get<int64_t>(), 0);
  EXPECT_GE(a["open"]["scan_s"].get<double>(), 0.0);

  const auto text = test::runVoxbrick("info " + (dir / "sparse.vdb").string());
  ASSERT_EQ(text.exitCode, 0) << text.output;
  EXPECT_NE(text.output.find("OpenVDB file, read live"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("scanning the tree"), std::string::npos) << text.output;

  const auto noGrid = test::runVoxbrick("info " + (dir / "sparse.vdb").string() + " --grid nothing");
  EXPECT_EQ(noGrid.exitCode, 1);
  EXPECT_NE(noGrid.output.find("has no grid named 'nothing'"), std::string::npos) << noGrid.output;
  const auto optionOnStore = test::runVoxbrick("info " + (dir / "prepped").string() + " --brick 8");
  EXPECT_EQ(optionOnStore.exitCode, 1);
  EXPECT_NE(optionOnStore.output.find("apply to a .vdb file only"), std::string::npos) << optionOnStore.output;
}

}  // namespace
}  // namespace voxbrick::store
