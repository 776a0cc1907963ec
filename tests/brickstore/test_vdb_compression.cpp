// The OpenVDB grid prep writes under each --vdb-compression: auto leaves blosc out where it does not halve the bytes
// (noise) and keeps it where it does (a smooth field); whichever, the file read live gives the prepped store's
// level-0 bricks, sample for sample.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickStore.h"
#include "brickstore/read/VdbStore.h"
#include "support/ArraySource.h"
#include "support/TestSupport.h"

namespace voxbrick::store {
namespace {

constexpr int kBrick = 8;
const Vec3i kDims{40, 36, 44};

/// Noise in [1, 2) (no voxel at the background), or a smooth field of a few distinct values.
std::vector<float> volume(bool noisy) {
  std::vector<float> v(size_t(kDims.volume()));
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> noise(1.0f, 2.0f);
  for (int64_t z = 0; z < kDims.z; ++z)
    for (int64_t y = 0; y < kDims.y; ++y)
      for (int64_t x = 0; x < kDims.x; ++x)
        v[size_t(x + kDims.x * (y + kDims.y * z))] = noisy ? noise(rng) : 1.0f + float((x / 5 + y / 7 + z / 3) % 4);
  return v;
}

/// Preps `values` with `compression` into `dir` (one VDB chunk) and returns the size of its .vdb file.
int64_t prepWith(const std::vector<float>& values, VdbCompression compression, const std::filesystem::path& dir) {
  test::ArraySource<float> source(kDims, ValueType::F32, values);
  PrepOptions options;
  options.brickSize = kBrick;
  options.vdbCompression = compression;
  prepStore(source, dir, options);
  const auto store = BrickStore::open(dir);
  EXPECT_EQ(store->meta().vdbFiles.size(), 1u);
  return int64_t(std::filesystem::file_size(dir / store->meta().vdbFiles.at(0)));
}

/// The .vdb file of the store in `dir`, read live, gives its level-0 bricks.
void expectLiveGridMatches(const std::filesystem::path& dir) {
  const auto prepped = BrickStore::open(dir);
  const auto live = VdbStore::open(dir / prepped->meta().vdbFiles.at(0), {"", kBrick});
  const LevelMeta& level = prepped->level(0);
  ASSERT_EQ(live->level(0).dims, level.dims);
  const size_t samples = size_t((kBrick + 2) * (kBrick + 2) * (kBrick + 2));
  std::vector<float> a(samples), b(samples);
  for (uint32_t k = 0; k < level.bricks.z; ++k)
    for (uint32_t j = 0; j < level.bricks.y; ++j)
      for (uint32_t i = 0; i < level.bricks.x; ++i) {
        const BrickKey key{0, i, j, k};
        prepped->readBrick(key, a.data());
        live->readBrick(key, b.data());
        ASSERT_TRUE(a == b) << toString(key);
      }
}

TEST(VdbCompression, AutoLeavesBloscOutOfNoiseAndTheGridReadsLive) {
  test::ScratchDir dir;
  const std::vector<float> noise = volume(true);
  const int64_t blosc = prepWith(noise, VdbCompression::Blosc, dir / "blosc");
  const int64_t none = prepWith(noise, VdbCompression::None, dir / "none");
  const int64_t automatic = prepWith(noise, VdbCompression::Auto, dir / "auto");
  EXPECT_LT(blosc, none) << "blosc still saves something on noise";
  EXPECT_GT(blosc, none / 2) << "but not half";
  EXPECT_EQ(automatic, none);
  for (const char* name : {"blosc", "none", "auto"}) expectLiveGridMatches(dir / name);
}

TEST(VdbCompression, AutoKeepsBloscWhereItHalvesTheBytes) {
  test::ScratchDir dir;
  const std::vector<float> smooth = volume(false);
  const int64_t blosc = prepWith(smooth, VdbCompression::Blosc, dir / "blosc");
  const int64_t none = prepWith(smooth, VdbCompression::None, dir / "none");
  const int64_t automatic = prepWith(smooth, VdbCompression::Auto, dir / "auto");
  EXPECT_LT(blosc, none / 2);
  EXPECT_EQ(automatic, blosc);
  for (const char* name : {"none", "auto"}) expectLiveGridMatches(dir / name);
}

}  // namespace
}  // namespace voxbrick::store
