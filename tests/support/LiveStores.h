// What the tests of the stores read live (VdbStore, ZarrStore) share: the store `voxbrick prep` makes of the same
// input, the brick keys of a level, and the comparisons of a live store's statistics, records and bricks with the
// prepped store's.
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <memory>
#include <vector>

#include "brickstore/ingest/Sources.h"
#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"

namespace voxbrick::test {

/// The store prep makes of `input` (a .vdb, an OME-Zarr) at `out` with bricks of `brick` (no VDB copy), opened.
inline std::shared_ptr<const store::BrickStore> prepOf(const std::filesystem::path& input,
                                                       const std::filesystem::path& out, int brick,
                                                       const store::SourceOptions& so = {}) {
  auto source = store::openSource(input.string(), so);
  store::PrepOptions options;
  options.brickSize = brick;
  options.writeVdb = false;
  store::prepStore(*source, out, options);
  return store::BrickStore::open(out);
}

/// Every brick key of `level` of `s`, x fastest.
inline std::vector<store::BrickKey> brickKeys(const store::BrickStore& s, int level) {
  const store::Vec3i nb = s.level(level).bricks;
  std::vector<store::BrickKey> keys;
  for (uint32_t k = 0; k < nb.z; ++k)
    for (uint32_t j = 0; j < nb.y; ++j)
      for (uint32_t i = 0; i < nb.x; ++i) keys.push_back({uint32_t(level), i, j, k});
  return keys;
}

/// Level 0's value range, active voxels and histogram counts equal the prepped store's (and the range is not empty).
inline void expectSameStats(const store::StoreMeta& live, const store::StoreMeta& prepped) {
  EXPECT_EQ(live.valueMin, prepped.valueMin);
  EXPECT_EQ(live.valueMax, prepped.valueMax);
  EXPECT_LT(live.valueMin, live.valueMax);
  EXPECT_EQ(live.activeVoxels, prepped.activeVoxels);
  EXPECT_EQ(live.histogram.counts, prepped.histogram.counts);
}

/// Every record of `level`: stored where the prepped store's is, with the same [min, max].
inline void expectSameRecords(const store::BrickStore& live, const store::BrickStore& prepped, int level) {
  for (const store::BrickKey& key : brickKeys(live, level)) {
    EXPECT_EQ(live.isStored(key), prepped.isStored(key)) << store::toString(key);
    EXPECT_EQ(live.record(key).min, prepped.record(key).min) << store::toString(key);
    EXPECT_EQ(live.record(key).max, prepped.record(key).max) << store::toString(key);
  }
}

/// The bricks `keys` read through the two caches have the same bytes (stops at the first that differs); returns
/// how many were compared.
inline int64_t expectSameBricks(store::BrickCache& live, store::BrickCache& prepped,
                                const std::vector<store::BrickKey>& keys) {
  int64_t compared = 0;
  for (const store::BrickKey& key : keys) {
    const store::BrickHandle a = live.get(key), b = prepped.get(key);
    EXPECT_EQ(a->bytes(), b->bytes());
    if (a->bytes() != b->bytes() || std::memcmp(a->data(), b->data(), a->bytes()) != 0) {
      ADD_FAILURE() << store::toString(key) << " differs from prep's";
      break;
    }
    ++compared;
  }
  return compared;
}

}  // namespace voxbrick::test
