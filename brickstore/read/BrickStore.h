// The read side of a store, as the host cache and the renderer see it: metadata, per-brick records, bricks with
// their borders and the min/max octree. Three backings: a prepped store directory (BrickStore::open), an OpenVDB
// file read live (VdbStore) and an OME-Zarr directory read live (ZarrStore), each a subclass that this base knows
// nothing of; openAnyStore (OpenAnyStore.h) picks one by the path's form.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "brickstore/format/StoreFormat.h"
#include "brickstore/format/StoreMeta.h"
#include "brickstore/read/MinMaxOctree.h"
#include "common/EnumNames.h"

namespace voxbrick::store {

/// What a store is read from.
enum class StoreBacking {
  Directory,      ///< a store directory written by `voxbrick prep`: compressed bricks on disk
  VdbFile,        ///< an OpenVDB file read live: bricks extracted from the grid's tree on demand
  ZarrDirectory,  ///< an OME-Zarr directory read live: bricks cut from its chunks on demand
};

/// "directory", "vdb-file" or "ome-zarr" (common::nameOf).
inline constexpr common::EnumName<StoreBacking> kStoreBackingNames[] = {{StoreBacking::Directory, "directory"},
                                                                        {StoreBacking::VdbFile, "vdb-file"},
                                                                        {StoreBacking::ZarrDirectory, "ome-zarr"}};
constexpr std::span<const common::EnumName<StoreBacking>> enumNames(StoreBacking) { return kStoreBackingNames; }

/// The samples of a brick ((B+2)^3 values of the store's type, as BrickStore::readBrick writes them), kept alive
/// by the pointer. A store whose coarse levels are derived from finer bricks asks for those through this; the host
/// cache passes its own get, so each finer brick is built once for every coarser brick that reads it.
using BrickSamplesFetch = std::function<std::shared_ptr<const void>(const BrickKey& key)>;

/// Options for opening a dataset file by its form (openAnyStore, brickstore/read/OpenAnyStore.h).
struct StoreOpenOptions {
  std::string gridName;  ///< .vdb: the float grid to read (default: the first float grid, as prep chooses)
  int brickSize = 32;    ///< .vdb and OME-Zarr: B, a power of two in [8, 256] (prep's default)
  int64_t time = 0;      ///< OME-Zarr: the index along its 't' axis
  int64_t channel = 0;   ///< OME-Zarr: the index along its 'c' axis
};

/// An open store. Immutable after opening; every method is safe to call from many threads at once.
///
/// Brick (i, j, k) of a level holds (B+2)^3 samples, x fastest: sample (a, b, c) is the level's voxel
/// (i*B + a - 1, j*B + b - 1, k*B + c - 1) with each coordinate clamped to [0, dims - 1] (the duplicated border).
/// Every backing gives the same samples for the same volume and brick size: a .vdb or an OME-Zarr read live equals
/// the store that `voxbrick prep` makes of it, level by level.
class BrickStore {
 public:
  /// Opens and validates a store directory (index checksums, sizes, metadata). Throws CorruptStoreError or
  /// IoError naming the file and the problem; never returns a half-valid store.
  static std::shared_ptr<const BrickStore> open(const std::filesystem::path& dir);

  virtual ~BrickStore();
  BrickStore(const BrickStore&) = delete;
  BrickStore& operator=(const BrickStore&) = delete;

  virtual StoreBacking backing() const = 0;
  /// The store directory or the .vdb file.
  const std::filesystem::path& path() const { return mPath; }
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
  /// The brick's record; throws InputError if the key is out of range. Its min and max bound the brick's samples
  /// (exactly for a store directory and for level 0 of a .vdb; see VdbStore for its coarser levels).
  const BrickRecord& record(const BrickKey& key) const;
  /// False for bricks known to hold only the background: they cost no I/O and no extraction.
  bool isStored(const BrickKey& key) const { return record(key).compressedSize != 0; }

  /// Writes brick `key` into dst (brickBytes() bytes, the store's type). A brick that is not stored is filled with
  /// the background without touching the disk or the grid. `finer` (may be empty) is where a store that derives
  /// coarse levels gets finer bricks; the other backing ignores it. Throws InputError for a key outside the store
  /// and CorruptStoreError if a brick's frame is corrupt.
  void readBrick(const BrickKey& key, void* dst, const BrickSamplesFetch& finer = {}) const;

  /// The min/max octree over level-0 bricks.
  const MinMaxOctree& octree() const { return mOctree; }

 protected:
  BrickStore() = default;

  /// The most level-0 bricks a store read live takes (its records, of every level, are held in memory).
  static constexpr int64_t kMaxLiveBricks = int64_t{1} << 26;

  /// Fills dst with brick `key`, which is stored (isStored) and inside the store.
  virtual void readStored(const BrickKey& key, void* dst, const BrickSamplesFetch& finer) const = 0;
  /// The index of `key`'s record in mRecords; the key must be inside the store.
  size_t recordIndex(const BrickKey& key) const;
  /// Builds mOctree from the level-0 records (so it can never disagree with them).
  void buildOctree();
  /// For a store read live: throws InputError where a level 0 of `dims` in bricks of `B` has more than
  /// kMaxLiveBricks bricks, before anything is sized from them (layOutLevels). `where` names the file and what gave
  /// the dims (as "dir/0/.zarray: field 'shape'").
  static void checkLiveBrickCount(const Vec3i& dims, int64_t B, const std::string& where);
  /// For a store read live: the pyramid's levels from mMeta.dims and mMeta.brickSize (mLevels, mMeta.levels) and a
  /// record per brick, all empty until the backing fills them.
  void layOutLevels();
  /// For a store read live: level m's records (m >= 1) from level m - 1's, as prep's pyramid would have them: a brick
  /// is stored if any finer brick under it is, its range the finer ones' (and the background where one is empty).
  void deriveCoarseRecords(int m);

  // Filled by the backing when it opens; immutable after.
  std::filesystem::path mPath;
  StoreMeta mMeta;
  std::vector<LevelEntry> mLevels;    ///< per level: dims, bricks, first record
  std::vector<BrickRecord> mRecords;  ///< every brick of every level, level after level
  MinMaxOctree mOctree;
};

}  // namespace voxbrick::store
