// The store's read side, and its directory backing: opening a prepped store checks every size, count and checksum
// before anything is sized from it.
#include "brickstore/read/BrickStore.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "brickstore/format/BrickFile.h"
#include "brickstore/format/BrickMath.h"
#include "brickstore/format/Errors.h"
#include "common/Checksum.h"

namespace voxbrick::store {
namespace fs = std::filesystem;
namespace {

std::string readText(const fs::path& path, size_t limit) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw CorruptStoreError(path.string() + ": missing (not a complete store)");
  auto size = fs::file_size(path, ec);
  if (ec) throw IoError("cannot stat " + path.string() + ": " + ec.message());
  if (size > limit)
    throw CorruptStoreError(path.string() + ": " + std::to_string(size) + " bytes, larger than any store writes");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(errnoMessage("cannot open " + path.string()));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/// Each level's bricks_stored and bytes_stored in store.json against what its index records hold.
void checkLevelCounts(const StoreMeta& meta, const std::vector<LevelEntry>& levels,
                      const std::vector<BrickRecord>& records, const std::string& metaName) {
  for (size_t l = 0; l < levels.size(); ++l) {
    const uint64_t first = levels[l].firstRecord;
    const uint64_t count = uint64_t(levels[l].bricks[0]) * levels[l].bricks[1] * levels[l].bricks[2];
    int64_t stored = 0, bytes = 0;
    for (uint64_t n = first; n < first + count; ++n)
      if (records[n].compressedSize != 0) ++stored, bytes += records[n].compressedSize;
    const LevelMeta& m = meta.levels[l];
    if (m.bricksStored != stored || m.bytesStored != bytes)
      throw CorruptStoreError(metaName + ": key 'levels' level " + std::to_string(l) + " says " +
                              std::to_string(m.bricksStored) + " bricks and " + std::to_string(m.bytesStored) +
                              " bytes stored; the index holds " + std::to_string(stored) + " and " +
                              std::to_string(bytes));
  }
}

/// A store directory written by `voxbrick prep`: bricks are zstd frames in bricks.bin, read with pread.
class DirectoryStore final : public BrickStore {
 public:
  static std::shared_ptr<const BrickStore> open(const fs::path& dir);

  StoreBacking backing() const override { return StoreBacking::Directory; }

 protected:
  void readStored(const BrickKey& key, void* dst, const BrickSamplesFetch&) const override {
    mFile.decode(mRecords[recordIndex(key)], key, dst, brickBytes());
  }

 private:
  DirectoryStore() = default;

  BrickFileReader mFile;
};

std::shared_ptr<const BrickStore> DirectoryStore::open(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw CorruptStoreError(dir.string() + ": not a store directory");
  std::shared_ptr<DirectoryStore> store(new DirectoryStore());
  store->mPath = dir;

  const fs::path metaPath = dir / "store.json";
  store->mMeta = StoreMeta::fromJson(readText(metaPath, 64 << 20), metaPath.string());
  const StoreMeta& meta = store->mMeta;
  const std::string indexName = (dir / "index.bin").string();

  // The index: header, then level entries, then records, each validated against the metadata.
  const std::string index = readText(dir / "index.bin", size_t{1} << 34);
  if (index.size() < sizeof(IndexHeader)) throw CorruptStoreError(indexName + ": truncated header");
  IndexHeader h;
  std::memcpy(&h, index.data(), sizeof h);
  if (std::memcmp(h.magic, kIndexMagic, sizeof h.magic) != 0) throw CorruptStoreError(indexName + ": bad magic");
  if (common::crc32Of(&h, offsetof(IndexHeader, headerCrc32)) != h.headerCrc32)
    throw CorruptStoreError(indexName + ": header checksum mismatch");
  if (h.version != kIndexVersion)
    throw CorruptStoreError(indexName + ": index version " + std::to_string(h.version) + ", this build reads " +
                            std::to_string(kIndexVersion));
  if (h.levelCount == 0 || h.levelCount > kMaxLevels || h.levelCount != meta.levels.size())
    throw CorruptStoreError(indexName + ": level count " + std::to_string(h.levelCount) +
                            " does not match store.json (" + std::to_string(meta.levels.size()) + ")");
  if (h.brickSize != uint32_t(meta.brickSize) || h.brickSize < 8 || h.brickSize > kMaxBrickSize ||
      (h.brickSize & (h.brickSize - 1)) != 0)
    throw CorruptStoreError(indexName + ": brick size " + std::to_string(h.brickSize) +
                            " is invalid or does not "
                            "match store.json");
  if (h.valueType != uint32_t(meta.type)) throw CorruptStoreError(indexName + ": value type does not match store.json");
  const uint64_t bodySize = index.size() - sizeof h;
  const uint64_t expected = uint64_t(h.levelCount) * sizeof(LevelEntry) + h.recordCount * sizeof(BrickRecord);
  if (h.recordCount > (uint64_t{1} << 40) || bodySize != expected)
    throw CorruptStoreError(indexName + ": " + std::to_string(bodySize) + " body bytes, expected " +
                            std::to_string(expected) + " (truncated or corrupt)");
  if (common::crc32Of(index.data() + sizeof h, bodySize) != h.bodyCrc32)
    throw CorruptStoreError(indexName + ": checksum mismatch (corrupt index)");

  store->mLevels.resize(h.levelCount);
  std::memcpy(store->mLevels.data(), index.data() + sizeof h, h.levelCount * sizeof(LevelEntry));
  uint64_t first = 0;
  for (uint32_t l = 0; l < h.levelCount; ++l) {
    const LevelEntry& e = store->mLevels[l];
    const LevelMeta& m = meta.levels[l];
    const int B = meta.brickSize;
    Vec3i dims{e.dims[0], e.dims[1], e.dims[2]};
    Vec3i bricks{e.bricks[0], e.bricks[1], e.bricks[2]};
    if (!(dims == m.dims) || !(bricks == m.bricks) || e.firstRecord != first ||
        !(bricks == Vec3i{divUp(dims.x, B), divUp(dims.y, B), divUp(dims.z, B)}))
      throw CorruptStoreError(indexName + ": level " + std::to_string(l) + " does not match store.json");
    first += uint64_t(bricks.volume());
  }
  if (first != h.recordCount) throw CorruptStoreError(indexName + ": record count does not match the levels");
  if (!(meta.levels[0].dims == meta.dims))
    throw CorruptStoreError(metaPath.string() + ": level 0 dims differ from dims");

  store->mRecords.resize(h.recordCount);
  std::memcpy(store->mRecords.data(), index.data() + sizeof h + h.levelCount * sizeof(LevelEntry),
              h.recordCount * sizeof(BrickRecord));

  store->mFile = BrickFileReader(dir / "bricks.bin", meta.type);
  const uint64_t bricksSize = store->mFile.fileSize();
  if (bricksSize != h.bricksFileSize)
    throw CorruptStoreError((dir / "bricks.bin").string() + ": " + std::to_string(bricksSize) +
                            " bytes, index expects " + std::to_string(h.bricksFileSize) + " (truncated or replaced)");
  for (const BrickRecord& r : store->mRecords)
    if (r.compressedSize != 0 && (r.offset > bricksSize || r.compressedSize > bricksSize - r.offset))
      throw CorruptStoreError(indexName + ": a brick record points past the end of bricks.bin");
  checkLevelCounts(meta, store->mLevels, store->mRecords, metaPath.string());
  checkLevelCounts(meta, store->mLevels, store->mRecords, metaPath.string());

  store->buildOctree();
  return store;
}

}  // namespace

BrickStore::~BrickStore() = default;

std::shared_ptr<const BrickStore> BrickStore::open(const fs::path& dir) { return DirectoryStore::open(dir); }

size_t BrickStore::brickBytes() const {
  const size_t e = static_cast<size_t>(brickEdge());
  return e * e * e * valueSize(mMeta.type);
}

void BrickStore::buildOctree() {
  const Vec3i nb = mMeta.levels.at(0).bricks;
  std::vector<MinMaxOctree::Range> ranges(static_cast<size_t>(nb.volume()));
  for (size_t n = 0; n < ranges.size(); ++n) ranges[n] = {mRecords[n].min, mRecords[n].max};
  mOctree = MinMaxOctree(nb, ranges);
}

bool BrickStore::contains(const BrickKey& key) const {
  if (key.level >= mLevels.size()) return false;
  const LevelEntry& e = mLevels[key.level];
  return key.i < e.bricks[0] && key.j < e.bricks[1] && key.k < e.bricks[2];
}

const BrickRecord& BrickStore::record(const BrickKey& key) const {
  if (!contains(key)) throw InputError("BrickStore::record: " + toString(key) + " is outside " + mPath.string());
  return mRecords[recordIndex(key)];
}

size_t BrickStore::recordIndex(const BrickKey& key) const {
  const LevelEntry& e = mLevels[key.level];
  return size_t(e.firstRecord + key.i + uint64_t(e.bricks[0]) * (key.j + uint64_t(e.bricks[1]) * key.k));
}

void BrickStore::checkLiveBrickCount(const Vec3i& dims, int64_t B, const std::string& where) {
  const double bricks = double(divUp(dims.x, B)) * double(divUp(dims.y, B)) * double(divUp(dims.z, B));
  if (bricks > double(kMaxLiveBricks))
    throw InputError(where + " " + dimsText(dims) + " in bricks of " + std::to_string(B) + " makes " +
                     std::to_string(int64_t(bricks)) + " bricks, more than 2^26 (use a larger --brick, or prep it)");
}

void BrickStore::layOutLevels() {
  uint64_t first = 0;
  for (const Vec3i& dims : pyramidDims(mMeta.dims, mMeta.brickSize)) {
    const Vec3i bricks{divUp(dims.x, mMeta.brickSize), divUp(dims.y, mMeta.brickSize), divUp(dims.z, mMeta.brickSize)};
    LevelEntry e{};
    for (int a = 0; a < 3; ++a) {
      e.dims[a] = dims[a];
      e.bricks[a] = uint32_t(bricks[a]);
    }
    e.firstRecord = first;
    first += uint64_t(bricks.volume());
    mLevels.push_back(e);
    mMeta.levels.push_back({dims, bricks, 0, 0});
  }
  mRecords.assign(first, BrickRecord{});
}

void BrickStore::deriveCoarseRecords(int m) {
  const int64_t B = mMeta.brickSize;
  const float background = float(mMeta.background);
  const uint32_t storedSize = uint32_t(brickBytes());
  const Vec3i nm = mMeta.levels[size_t(m)].dims, nf = mMeta.levels[size_t(m) - 1].dims;
  const Vec3i nb = mMeta.levels[size_t(m)].bricks;
  for (int64_t k = 0; k < nb.z; ++k)
    for (int64_t j = 0; j < nb.y; ++j)
      for (int64_t i = 0; i < nb.x; ++i) {
        Vec3i lo, hi;
        brickVoxels({i, j, k}, B, nm, lo, hi);
        bool stored = false, someEmpty = false;
        float mn = std::numeric_limits<float>::max(), mx = std::numeric_limits<float>::lowest();
        for (int64_t fk = 2 * lo.z / B; fk <= std::min(2 * hi.z + 1, nf.z - 1) / B; ++fk)
          for (int64_t fj = 2 * lo.y / B; fj <= std::min(2 * hi.y + 1, nf.y - 1) / B; ++fj)
            for (int64_t fi = 2 * lo.x / B; fi <= std::min(2 * hi.x + 1, nf.x - 1) / B; ++fi) {
              const BrickRecord& f = mRecords[recordIndex({uint32_t(m - 1), uint32_t(fi), uint32_t(fj), uint32_t(fk)})];
              stored = stored || f.compressedSize != 0;
              someEmpty = someEmpty || f.compressedSize == 0;
              mn = std::min(mn, f.min);
              mx = std::max(mx, f.max);
            }
        BrickRecord& rec = mRecords[recordIndex({uint32_t(m), uint32_t(i), uint32_t(j), uint32_t(k)})];
        if (someEmpty) mn = std::min(mn, background), mx = std::max(mx, background);
        rec = stored ? BrickRecord{0, storedSize, 0, mn, mx, 0} : BrickRecord{0, 0, 0, background, background, 0};
        mMeta.levels[size_t(m)].bricksStored += stored;
      }
}

void BrickStore::readBrick(const BrickKey& key, void* dst, const BrickSamplesFetch& finer) const {
  if (!isStored(key)) {
    const size_t e = static_cast<size_t>(brickEdge());
    fillValue(mMeta.type, mMeta.background, dst, e * e * e);
    return;
  }
  readStored(key, dst, finer);
}

}  // namespace voxbrick::store
