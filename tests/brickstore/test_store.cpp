// The store written by prep, read back: voxels, borders, sparsity, octree, LOD pyramid, VDB grid, atomicity.
#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include "brickstore/format/Errors.h"
#include "brickstore/prep/LevelSources.h"
#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickStore.h"
#include "support/ArraySource.h"
#include "support/TestSupport.h"

namespace voxbrick::store {
namespace {

using test::ArraySource;
using test::ScratchDir;

/// A plain dense copy of a volume, and the straightforward operations the store must agree with.
template <typename T>
struct Dense {
  Vec3i n;
  std::vector<T> v;
  T at(int64_t x, int64_t y, int64_t z) const {
    x = std::clamp<int64_t>(x, 0, n.x - 1);
    y = std::clamp<int64_t>(y, 0, n.y - 1);
    z = std::clamp<int64_t>(z, 0, n.z - 1);
    return v[size_t(x + n.x * (y + n.y * z))];
  }
  Dense downsample() const {
    Dense d{{divUp(n.x, 2), divUp(n.y, 2), divUp(n.z, 2)}, {}};
    d.v.resize(size_t(d.n.volume()));
    for (int64_t z = 0; z < d.n.z; ++z)
      for (int64_t y = 0; y < d.n.y; ++y)
        for (int64_t x = 0; x < d.n.x; ++x) {
          double sum = 0;
          for (int dz = 0; dz < 2; ++dz)
            for (int dy = 0; dy < 2; ++dy)
              for (int dx = 0; dx < 2; ++dx) sum += double(at(2 * x + dx, 2 * y + dy, 2 * z + dz));
          d.v[size_t(x + d.n.x * (y + d.n.y * z))] = downsampleAverage<T>(sum);
        }
    return d;
  }
};

/// Checks every sample of every brick of one level against the dense level, borders included.
template <typename T>
void expectLevelMatches(const BrickStore& s, uint32_t level, const Dense<T>& d, double background) {
  const int64_t B = s.brickSize(), E = B + 2;
  const LevelMeta& lm = s.level(int(level));
  ASSERT_EQ(lm.dims, d.n);
  std::vector<T> brick(size_t(E * E * E));
  int64_t stored = 0;
  for (uint32_t k = 0; k < lm.bricks.z; ++k)
    for (uint32_t j = 0; j < lm.bricks.y; ++j)
      for (uint32_t i = 0; i < lm.bricks.x; ++i) {
        BrickKey key{level, i, j, k};
        s.readBrick(key, brick.data());
        bool allBackground = true;
        T lo = brick[0], hi = brick[0];
        for (int64_t c = 0; c < E; ++c)
          for (int64_t b = 0; b < E; ++b)
            for (int64_t a = 0; a < E; ++a) {
              const T want = d.at(i * B + a - 1, j * B + b - 1, k * B + c - 1);
              const T got = brick[size_t(a + E * (b + E * c))];
              ASSERT_EQ(got, want) << toString(key) << " sample " << a << "," << b << "," << c;
              allBackground = allBackground && want == static_cast<T>(background);
              lo = std::min(lo, want);
              hi = std::max(hi, want);
            }
        EXPECT_EQ(s.isStored(key), !allBackground) << toString(key);
        EXPECT_EQ(s.record(key).min, float(lo)) << toString(key);
        EXPECT_EQ(s.record(key).max, float(hi)) << toString(key);
        stored += s.isStored(key);
      }
  EXPECT_EQ(lm.bricksStored, stored);
}

template <typename T>
Dense<T> makeVolume(Vec3i n, double lo, double hi, uint32_t seed, bool sparse, int64_t radius = 14) {
  Dense<T> d{n, test::randomVolume<T>(n, lo, hi, seed)};
  if (sparse)  // keep only a ball around one corner so most bricks are empty
    for (int64_t z = 0; z < n.z; ++z)
      for (int64_t y = 0; y < n.y; ++y)
        for (int64_t x = 0; x < n.x; ++x)
          if (x * x + y * y + z * z > radius * radius) d.v[size_t(x + n.x * (y + n.y * z))] = T(0);
  return d;
}

template <typename T>
std::shared_ptr<const BrickStore> prepDense(const Dense<T>& d, ValueType type, const std::filesystem::path& out, int B,
                                            PrepOptions options = {}) {
  ArraySource<T> src(d.n, type, d.v);
  options.brickSize = B;
  prepStore(src, out, options);
  return BrickStore::open(out);
}

TEST(StoreRoundTrip, EveryVoxelAndBorderOfEveryLevelU16) {
  ScratchDir dir;
  auto d = makeVolume<uint16_t>({45, 37, 29}, 0, 65535, 1, false);
  auto s = prepDense(d, ValueType::U16, dir / "s", 8);
  ASSERT_EQ(s->levelCount(), 4);  // 45 -> 23 -> 12 -> 6 fits one brick of 8
  Dense<uint16_t> level = d;
  for (int l = 0; l < s->levelCount(); ++l) {
    SCOPED_TRACE("level " + std::to_string(l));
    expectLevelMatches(*s, uint32_t(l), level, 0);
    level = level.downsample();
  }
  EXPECT_EQ(s->meta().dims, d.n);
  EXPECT_EQ(s->meta().type, ValueType::U16);
  EXPECT_EQ(s->meta().valueMin, *std::min_element(d.v.begin(), d.v.end()));
  EXPECT_EQ(s->meta().valueMax, *std::max_element(d.v.begin(), d.v.end()));
}

TEST(StoreRoundTrip, FloatAndByteAndSignedTypes) {
  ScratchDir dir;
  auto f = makeVolume<float>({33, 17, 40}, -5, 5, 2, false);
  auto sf = prepDense(f, ValueType::F32, dir / "f", 16);
  expectLevelMatches(*sf, 0, f, 0);
  expectLevelMatches(*sf, 1, f.downsample(), 0);
  auto b = makeVolume<uint8_t>({20, 9, 31}, 0, 255, 3, false);
  expectLevelMatches(*prepDense(b, ValueType::U8, dir / "b", 8), 0, b, 0);
  auto i = makeVolume<int16_t>({16, 16, 16}, -32768, 32767, 4, false);
  expectLevelMatches(*prepDense(i, ValueType::I16, dir / "i", 16), 0, i, 0);
}

TEST(StoreRoundTrip, EncodingTwiceGivesTheSameBytes) {
  ScratchDir dir;
  auto d = makeVolume<float>({40, 30, 20}, 0, 1, 5, true);
  PrepOptions noVdb;
  noVdb.writeVdb = false;
  prepDense(d, ValueType::F32, dir / "a", 8, noVdb);
  prepDense(d, ValueType::F32, dir / "b", 8, noVdb);
  for (const char* f : {"bricks.bin", "index.bin", "store.json"})
    EXPECT_EQ(test::readFile(dir / "a" / f), test::readFile(dir / "b" / f)) << f;
}

TEST(StoreRoundTrip, ThreadsAndSlabsInFlightDoNotChangeTheBytes) {
  // One thread cuts one slab at a time; two threads read ahead (up to three slabs in flight) and write the OpenVDB
  // chunks beside the cutting. The files must not tell them apart (OpenVDB's random file UUID aside).
  ScratchDir dir;
  auto d = makeVolume<float>({70, 50, 90}, -1, 1, 6, true, 60);
  auto withThreads = [](int threads) {
    PrepOptions o;
    o.threads = threads;
    o.vdbChunkSlices = 24;  // several chunks, not on slab boundaries
    return o;
  };
  prepDense(d, ValueType::F32, dir / "one", 8, withThreads(1));
  prepDense(d, ValueType::F32, dir / "two", 8, withThreads(2));
  for (const char* f : {"bricks.bin", "index.bin", "store.json"})
    EXPECT_EQ(test::readFile(dir / "one" / f), test::readFile(dir / "two" / f)) << f;
  int vdbFiles = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir / "one" / "vdb")) {
    std::vector<char> a = test::readFile(entry.path());
    std::vector<char> b = test::readFile(dir / "two" / "vdb" / entry.path().filename());
    ASSERT_GT(a.size(), 57u);
    ASSERT_EQ(a.size(), b.size()) << entry.path();
    std::fill_n(a.begin() + 21, 36, '-');  // the UUID
    std::fill_n(b.begin() + 21, 36, '-');
    EXPECT_TRUE(a == b) << entry.path();
    ++vdbFiles;
  }
  EXPECT_EQ(vdbFiles, 4);  // z = 0, 24, 48, 72
}

TEST(StoreSparse, EmptyBricksAreAbsentAndCostNothing) {
  ScratchDir dir;
  auto d = makeVolume<float>({64, 64, 64}, 0.5, 1, 6, true, 20);
  auto s = prepDense(d, ValueType::F32, dir / "s", 16);
  const LevelMeta& l0 = s->level(0);
  EXPECT_EQ(l0.bricksTotal(), 64);
  // The ball of radius 20 around voxel 0 reaches brick (0,0,0) and, through their borders starting at voxel 15,
  // bricks (1,0,0), (0,1,0), (0,0,1); (1,1,0) starts at distance 15*sqrt(2) > 20.
  EXPECT_EQ(l0.bricksStored, 4);
  expectLevelMatches(*s, 0, d, 0);
  // An absent brick is all background and has no bytes on disk.
  const BrickRecord& far = s->record({0, 3, 3, 3});
  EXPECT_EQ(far.compressedSize, 0u);
  EXPECT_EQ(far.min, 0.0f);
  EXPECT_EQ(far.max, 0.0f);
  // The stored bytes are a small fraction of the raw bytes.
  EXPECT_LT(s->meta().bytesStored, s->meta().bytesRaw / 4);
}

TEST(StoreOctree, NodeRangesAreExactMinMaxOfTheirBricks) {
  ScratchDir dir;
  auto d = makeVolume<uint16_t>({70, 41, 23}, 100, 60000, 7, true);
  auto s = prepDense(d, ValueType::U16, dir / "s", 8);
  const MinMaxOctree& o = s->octree();
  EXPECT_EQ(o.depth(), 4);  // 9 x 6 x 3 bricks -> 16
  const int64_t B = 8;
  for (int depth = 0; depth <= o.depth(); ++depth) {
    Vec3i nodes = o.nodesAt(depth);
    for (int64_t k = 0; k < nodes.z; ++k)
      for (int64_t j = 0; j < nodes.y; ++j)
        for (int64_t i = 0; i < nodes.x; ++i) {
          ASSERT_TRUE(o.exists(depth, i, j, k));
          Vec3i lo, hi;
          o.brickSpan(depth, i, j, k, lo, hi);
          float mn = 1e30f, mx = -1e30f;
          for (int64_t z = lo.z * B - 1; z <= hi.z * B; ++z)
            for (int64_t y = lo.y * B - 1; y <= hi.y * B; ++y)
              for (int64_t x = lo.x * B - 1; x <= hi.x * B; ++x) {
                mn = std::min(mn, float(d.at(x, y, z)));
                mx = std::max(mx, float(d.at(x, y, z)));
              }
          auto r = o.range(depth, i, j, k);
          ASSERT_EQ(r.min, mn) << "node " << depth << " " << i << "," << j << "," << k;
          ASSERT_EQ(r.max, mx) << "node " << depth << " " << i << "," << j << "," << k;
        }
    EXPECT_FALSE(o.exists(depth, nodes.x, 0, 0));
  }
  EXPECT_EQ(o.range(0, 0, 0, 0).min, float(*std::min_element(d.v.begin(), d.v.end())));
}

TEST(StoreVdb, CanonicalGridHoldsEveryVoxelWithEmptySpaceInactive) {
  ScratchDir dir;
  auto d = makeVolume<float>({30, 20, 50}, 1, 2, 8, true);
  PrepOptions options;
  options.vdbChunkSlices = 8;
  auto s = prepDense(d, ValueType::F32, dir / "s", 8, options);
  ASSERT_GT(s->meta().vdbFiles.size(), 1u);
  openvdb::initialize();
  int64_t active = 0;
  for (const std::string& name : s->meta().vdbFiles) {
    openvdb::io::File file((dir / "s" / name).string());
    file.open();
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("density"));
    ASSERT_TRUE(grid);
    const int64_t z0 = grid->metaValue<int64_t>("voxbrick_chunk_z0");
    auto acc = grid->getConstAccessor();
    for (auto it = grid->cbeginValueOn(); it; ++it) active += int64_t(it.getVoxelCount());
    for (int64_t z = z0; z < std::min<int64_t>(z0 + 8, d.n.z); ++z)
      for (int64_t y = 0; y < d.n.y; ++y)
        for (int64_t x = 0; x < d.n.x; ++x) {
          const openvdb::Coord c{int(x), int(y), int(z)};
          ASSERT_EQ(acc.getValue(c), d.at(x, y, z));
          ASSERT_EQ(acc.isValueOn(c), d.at(x, y, z) != 0.0f);
        }
    // The transform puts voxel centres where the optical model does.
    auto world = grid->transform().indexToWorld(openvdb::Vec3d(0, 0, 0));
    EXPECT_NEAR(world.x(), 0.5 - 15.0, 1e-12);
    EXPECT_NEAR(world.z(), 0.5 - 25.0, 1e-12);
  }
  EXPECT_EQ(active, s->meta().activeVoxels);
}

TEST(StoreAtomic, FailedPrepLeavesNoStoreAndKeepsTheOldOne) {
  ScratchDir dir;
  auto d = makeVolume<uint8_t>({20, 20, 40}, 0, 255, 9, false);
  auto old = prepDense(d, ValueType::U8, dir / "s", 8);
  const auto oldIndex = test::readFile(dir / "s" / "index.bin");

  auto other = makeVolume<uint8_t>({20, 20, 40}, 0, 255, 10, false);
  ArraySource<uint8_t> failing(other.n, ValueType::U8, other.v);
  failing.failAt(25);
  PrepOptions options;
  options.brickSize = 8;
  options.overwrite = true;
  EXPECT_THROW(prepStore(failing, dir / "s", options), InputError);
  EXPECT_EQ(test::readFile(dir / "s" / "index.bin"), oldIndex);
  EXPECT_NO_THROW(BrickStore::open(dir / "s"));
  for (auto& entry : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(entry.path().filename(), "s") << "left behind: " << entry.path();

  // Without --force an existing store is refused; with it, replaced.
  ArraySource<uint8_t> good(other.n, ValueType::U8, other.v);
  options.overwrite = false;
  EXPECT_THROW(prepStore(good, dir / "s", options), InputError);
  options.overwrite = true;
  prepStore(good, dir / "s", options);
  expectLevelMatches(*BrickStore::open(dir / "s"), 0, other, 0);
}

/// --force swaps the new store in: a reader looking at the path all along always finds a store there.
TEST(StoreAtomic, AReplacedStoreIsAlwaysAtItsPath) {
  ScratchDir dir;
  auto d = makeVolume<uint8_t>({16, 16, 16}, 0, 255, 12, false);
  PrepOptions options;
  options.overwrite = true;
  options.writeVdb = false;
  prepDense(d, ValueType::U8, dir / "s", 8, options);
  std::atomic<bool> done{false};
  std::atomic<int> looks{0}, missing{0};
  std::thread reader([&] {
    while (!done) {
      std::error_code ec;
      if (!std::filesystem::exists(dir / "s" / "store.json", ec)) ++missing;
      ++looks;
    }
  });
  for (int i = 0; i < 10; ++i) prepDense(d, ValueType::U8, dir / "s", 8, options);
  done = true;
  reader.join();
  EXPECT_GT(looks.load(), 0);
  EXPECT_EQ(missing.load(), 0) << "of " << looks.load() << " looks";
  expectLevelMatches(*BrickStore::open(dir / "s"), 0, d, 0);
  for (auto& entry : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(entry.path().filename(), "s") << "left behind: " << entry.path();
}

TEST(StoreCorrupt, DamagedFilesAreRejectedWithTheirName) {
  ScratchDir dir;
  auto d = makeVolume<float>({24, 24, 24}, 0, 1, 11, false);
  prepDense(d, ValueType::F32, dir / "good", 8);
  auto damaged = [&](const std::string& name, auto&& damage) {
    std::filesystem::copy(dir / "good", dir / name, std::filesystem::copy_options::recursive);
    damage(dir / name);
    return dir / name;
  };
  auto expectOpenFails = [](const std::filesystem::path& p, const std::string& words) {
    try {
      BrickStore::open(p);
      ADD_FAILURE() << "opened a damaged store " << p;
    } catch (const StoreError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  auto flipByte = [](const std::filesystem::path& file, size_t offset) {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(std::streamoff(offset));
    char c;
    f.get(c);
    f.seekp(std::streamoff(offset));
    f.put(char(c ^ 0x5A));
  };
  expectOpenFails(damaged("idx", [&](auto p) { flipByte(p / "index.bin", 200); }), "checksum");
  expectOpenFails(damaged("hdr", [&](auto p) { flipByte(p / "index.bin", 13); }), "index.bin");
  expectOpenFails(damaged("trunc-idx", [](auto p) { std::filesystem::resize_file(p / "index.bin", 100); }),
                  "index.bin");
  expectOpenFails(damaged("trunc-bricks", [](auto p) { std::filesystem::resize_file(p / "bricks.bin", 1000); }),
                  "bricks.bin");
  expectOpenFails(damaged("no-meta", [](auto p) { std::filesystem::remove(p / "store.json"); }), "store.json");
  expectOpenFails(damaged("bad-meta", [](auto p) { test::writeFile(p / "store.json", std::string("{\"format\":")); }),
                  "store.json");
  expectOpenFails(dir / "missing", "not a store");

  // A corrupt frame opens (the index is intact) but that brick fails to decode, naming it.
  auto frame = damaged("frame", [&](auto p) { flipByte(p / "bricks.bin", 500); });
  auto s = BrickStore::open(frame);
  std::vector<float> brick(s->brickBytes() / sizeof(float));
  EXPECT_THROW(s->readBrick({0, 0, 0, 0}, brick.data()), CorruptStoreError);
  EXPECT_NO_THROW(s->readBrick({0, 2, 2, 2}, brick.data()));
}

TEST(StoreOptions, RejectsAbsurdOptions) {
  ScratchDir dir;
  auto d = makeVolume<float>({8, 8, 8}, 0, 1, 12, false);
  ArraySource<float> src(d.n, ValueType::F32, d.v);
  PrepOptions options;
  options.brickSize = 12;
  EXPECT_THROW(prepStore(src, dir / "s", options), InputError);
  options.brickSize = 8;
  options.memoryBudgetMB = 0;
  EXPECT_THROW(prepStore(src, dir / "s", options), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir / "s"));
}

TEST(StoreNonFinite, ReplacedByBackgroundAndCountedOrRefused) {
  ScratchDir dir;
  Dense<float> d{{10, 10, 10}, std::vector<float>(1000, 1.0f)};
  d.v[5] = std::nanf("");
  d.v[77] = INFINITY;
  d.v[999] = -INFINITY;
  auto s = prepDense(d, ValueType::F32, dir / "s", 8);
  EXPECT_EQ(s->meta().nonFiniteReplaced, 3);
  EXPECT_EQ(s->meta().valueMin, 0.0);
  EXPECT_EQ(s->meta().valueMax, 1.0);
  ArraySource<float> src(d.n, ValueType::F32, d.v);
  PrepOptions options;
  options.brickSize = 8;
  options.nonFinite = NonFinitePolicy::Error;
  try {
    prepStore(src, dir / "e", options);
    ADD_FAILURE() << "accepted NaN with policy error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("voxel (5, 0, 0)"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace voxbrick::store
