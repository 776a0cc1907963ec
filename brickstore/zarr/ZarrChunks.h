// The chunks of an OME-Zarr's pyramid levels: which exist, decoding them (none, zlib, gzip, zstd, blosc) through a
// bounded cache of decoded chunks, and cutting any box of voxels out of them in the store's type. Shared by the live
// store (ZarrStore) and prep's source (ZarrSource).
#pragma once

#include <atomic>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "brickstore/zarr/ZarrMeta.h"

namespace voxbrick::store {

/// Decodes the bytes of one chunk file of array `a` into `out`, exactly a.chunkBytes() bytes (the file's dtype and
/// order). Throws CorruptStoreError naming `name` when the data is truncated, corrupt or of another decoded size.
/// Used by ZarrChunks and by the decode benchmark.
void decodeZarrChunk(const ZarrArrayMeta& a, const std::vector<unsigned char>& file, const std::string& name,
                     unsigned char* out);

/// The chunks of every level of one OME-Zarr (one time point and channel), read on demand. Thread-safe.
class ZarrChunks {
 public:
  /// Scans which chunk files of the chosen (t, c) exist (one stat per chunk; no chunk is read). `cacheBytes` bounds
  /// the decoded chunks kept (at least one chunk is kept whatever the bound).
  ZarrChunks(ZarrMeta meta, size_t cacheBytes);

  const ZarrMeta& meta() const { return mMeta; }
  int levelCount() const { return int(mMeta.levels.size()); }
  /// The store type values are delivered in, and the background (fill value) in it.
  ValueType type() const { return mType; }
  double background() const { return mBackground; }

  /// True if a chunk file covering any voxel of level `level`'s box [lo, hi] (inclusive) exists: false means every
  /// voxel there is the fill value, known without reading anything.
  bool anyChunk(int level, const Vec3i& lo, const Vec3i& hi) const;
  /// Chunk files present at `level`.
  int64_t chunksPresent(int level) const;

  /// Writes voxels [lo, hi] of level `level` into dst, x fastest, in type(): missing chunks give the fill value,
  /// NaN and Inf give the background. Throws CorruptStoreError naming the chunk file that cannot be decoded.
  void readRegion(int level, const Vec3i& lo, const Vec3i& hi, void* dst) const;

  /// Chunks decoded since construction (cache misses), for statistics.
  int64_t chunksDecoded() const { return mDecoded.load(std::memory_order_relaxed); }

 private:
  struct DecodedChunk {
    std::unique_ptr<unsigned char[]> bytes;  // not zeroed before decoding
    size_t size = 0;
  };
  using Chunk = std::shared_ptr<const DecodedChunk>;
  Chunk chunk(int level, const Vec3i& c) const;
  void copyFromChunk(int level, const Vec3i& c, const Chunk& data, const Vec3i& lo, const Vec3i& hi, const Vec3i& rlo,
                     const Vec3i& rhi, unsigned char* dst) const;

  ZarrMeta mMeta;
  ValueType mType;
  double mBackground;
  std::vector<int64_t> mFixedChunk, mFixedIn;
  std::vector<std::vector<uint8_t>> mExists;  // per level, per spatial chunk (x fastest)
  size_t mCacheBytes;

  mutable std::mutex mMutex;
  mutable std::list<std::pair<uint64_t, Chunk>> mLru;  // most recent first
  mutable std::unordered_map<uint64_t, std::list<std::pair<uint64_t, Chunk>>::iterator> mIndex;
  mutable size_t mHeld = 0;
  mutable std::atomic<int64_t> mDecoded{0};
};

}  // namespace voxbrick::store
