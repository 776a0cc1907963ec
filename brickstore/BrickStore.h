// Read-only access to a prepared store: metadata, per-brick records, decoded bricks and the min/max octree.
#pragma once

#include <filesystem>
#include <memory>
#include <vector>

#include "brickstore/MinMaxOctree.h"
#include "brickstore/StoreFormat.h"
#include "brickstore/StoreMeta.h"

namespace voxbrick::store {

struct BrickStoreFile;

/// An open store. Immutable after open(); every method is safe to call from many threads at once.
///
/// Brick (i, j, k) of a level holds (B+2)^3 samples, x fastest: sample (a, b, c) is the level's voxel
/// (i*B + a - 1, j*B + b - 1, k*B + c - 1) with each coordinate clamped to [0, dims - 1] (the duplicated border).
class BrickStore {
 public:
  /// Opens and validates a store directory (index checksums, sizes, metadata). Throws CorruptStoreError or
  /// IoError naming the file and the problem; never returns a half-valid store.
  static std::shared_ptr<const BrickStore> open(const std::filesystem::path& dir);

  ~BrickStore();
  BrickStore(const BrickStore&) = delete;
  BrickStore& operator=(const BrickStore&) = delete;

  const std::filesystem::path& path() const { return mDir; }
  const StoreMeta& meta() const { return mMeta; }
  int levelCount() const { return static_cast<int>(mMeta.levels.size()); }
  const LevelMeta& level(int l) const { return mMeta.levels.at(static_cast<size_t>(l)); }
  int brickSize() const { return mMeta.brickSize; }
  ValueType type() const { return mMeta.type; }
  /// Samples per brick edge, B + 2.
  int brickEdge() const { return mMeta.brickSize + 2; }
  /// Bytes of one decoded brick: (B+2)^3 times the type size.
  size_t brickBytes() const;

  /// True if `key` names a brick of the store (level and indices in range).
  bool contains(const BrickKey& key) const;
  /// The brick's index record; throws InputError if the key is out of range.
  const BrickRecord& record(const BrickKey& key) const;
  /// False for bricks whose every sample equals the background (they are not stored and cost no I/O).
  bool isStored(const BrickKey& key) const { return record(key).compressedSize != 0; }

  /// Decodes brick `key` into dst (brickBytes() bytes, the store's type). A brick that is not stored is filled
  /// with the background without touching the disk. Throws CorruptStoreError if its frame is corrupt.
  void readBrick(const BrickKey& key, void* dst) const;

  /// The min/max octree over level-0 bricks.
  const MinMaxOctree& octree() const { return mOctree; }

 private:
  BrickStore() = default;

  std::filesystem::path mDir;
  StoreMeta mMeta;
  std::vector<LevelEntry> mLevels;
  std::vector<BrickRecord> mRecords;
  MinMaxOctree mOctree;
  std::unique_ptr<BrickStoreFile> mFile;
};

}  // namespace voxbrick::store
