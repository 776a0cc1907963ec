// An OME-Zarr directory read live as a store: bricks with their borders cut from the chunks on demand, the dataset's
// own pyramid levels used as LOD levels where they halve each axis, the others averaged from the level below. The
// same bricks as the store `voxbrick prep` makes of the directory.
#pragma once

#include <atomic>
#include <filesystem>
#include <memory>

#include "brickstore/read/BrickStore.h"
#include "brickstore/zarr/ZarrChunks.h"

namespace voxbrick::store {

/// What opening an OME-Zarr cost and found.
struct ZarrOpenStats {
  double scanSeconds = 0;     ///< the pass over the chunks: existence, brick ranges, statistics, histogram
  int64_t chunksPresent = 0;  ///< chunk files of level 0 (for the chosen time and channel)
  int64_t chunksTotal = 0;    ///< chunks of level 0's grid
  int64_t bricksScanned = 0;  ///< bricks of the own levels read at open: those touching a present chunk
  int64_t chunksDecoded = 0;  ///< chunk decodes during open
  int ownLevels = 0;          ///< store levels that are the Zarr's own datasets (level 0 included)
};

/// One time point and channel of an OME-Zarr read as a store of bricks of B^3 voxels.
///
/// Values are the chunks' converted to the store type (as prep converts them: u8, u16, i16 kept, int8 widened, the
/// rest f32, NaN and Inf as the background); the background is the fill value; missing chunk files are the fill
/// value, known from a scan of which files exist, so bricks that touch only missing chunks are never read.
///
/// Opening makes one pass over the bricks of the own levels that touch a present chunk, for their exact [min, max]
/// and emptiness (exactly the prepped store's records, and so its octree), and the level-0 value range and active
/// voxels. For u8, u16 and i16 the same pass counts level 0's voxels by value, which gives the histogram; for f32
/// the histogram, binned over the range, takes a second pass over level 0's stored bricks.
/// Coarse levels that are not the Zarr's own are averaged from the finer bricks through the `finer` fetch, with
/// records bounded from the finer records (as VdbStore does).
class ZarrStore final : public BrickStore, public std::enable_shared_from_this<ZarrStore> {
 public:
  /// Decoded chunks kept by default.
  static constexpr size_t kChunkCacheBytes = size_t{256} << 20;

  /// Opens `dir` (an OME-Zarr group) with options.time, options.channel and options.brickSize, keeping up to
  /// `chunkCacheBytes` of decoded chunks (at least one). Throws InputError naming the file and the field,
  /// CorruptStoreError naming a chunk that cannot be decoded, and IoError.
  static std::shared_ptr<const ZarrStore> open(const std::filesystem::path& dir, const StoreOpenOptions& options = {},
                                               size_t chunkCacheBytes = kChunkCacheBytes);

  ~ZarrStore() override;

  StoreBacking backing() const override { return StoreBacking::ZarrDirectory; }
  const ZarrOpenStats& openStats() const { return mOpenStats; }
  const ZarrChunks& chunks() const { return *mChunks; }
  /// Per store level, whether it is the Zarr's own dataset (else averaged from the level below).
  const std::vector<bool>& ownLevels() const { return mOwn; }

 protected:
  void readStored(const BrickKey& key, void* dst, const BrickSamplesFetch& finer) const override;

 private:
  struct Level0Scan;

  ZarrStore() = default;
  /// Reads the records of own level `level`; for level 0 also returns the statistics of the owned voxels.
  Level0Scan scanOwnLevel(int level);
  /// Level 0's value range, active voxels and histogram from the scan (and, for f32, a pass for the histogram).
  void level0Statistics(Level0Scan level0);
  void statisticsFromCounts(std::vector<uint64_t> counts, int64_t emptyVoxels);

  std::unique_ptr<ZarrChunks> mChunks;
  std::vector<bool> mOwn;
  ZarrOpenStats mOpenStats;
};

}  // namespace voxbrick::store
