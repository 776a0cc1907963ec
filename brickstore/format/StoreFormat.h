// On-disk layout of a store's binary index (index.bin). Little-endian; pinned by tests/brickstore/test_format.cpp.
//
// A store is a directory:
//   store.json        metadata (written last; a directory without it is not a store)
//   index.bin         IndexHeader, then levelCount LevelEntry, then one BrickRecord per brick of every level
//   bricks.bin        zstd frames, one per stored brick, at BrickRecord::offset; a frame holds the brick's
//                     (B+2)^3 samples, x fastest, and for 2- and 4-byte types its bytes are shuffled into planes
//                     (byte 0 of every sample, then byte 1, ...) before compression
//   vdb/level0-zNNNNN.vdb   the canonical OpenVDB float grid of level 0, one file per z-chunk
//
// index.bin:
//   offset  size  IndexHeader
//        0     8  magic "VXBINDEX"
//        8     4  version (kIndexVersion)
//       12     4  levelCount
//       16     4  brickSize B
//       20     4  valueType (ValueType)
//       24     8  bricksFileSize (must equal the size of bricks.bin)
//       32     8  recordCount (sum of bricks over all levels)
//       40     4  bodyCrc32 (CRC-32 of every byte after the header)
//       44     4  headerCrc32 (CRC-32 of bytes 0..43)
//       48    16  reserved, zero
//   then per level, LevelEntry (48 bytes):
//        0    24  dims x, y, z (int64)
//       24    12  bricks x, y, z (uint32)
//       36     4  reserved, zero
//       40     8  firstRecord (index of the level's first BrickRecord)
//   then BrickRecord (32 bytes) for brick (i, j, k) of level l at firstRecord + i + bx * (j + by * k):
//        0     8  offset in bricks.bin
//        8     4  compressedSize (0: not stored, every sample equals the background)
//       12     4  flags (reserved, zero)
//       16     4  min over the (B+2)^3 samples, border included (float)
//       20     4  max likewise
//       24     8  reserved, zero
#pragma once

#include <cstdint>

namespace voxbrick::store {

inline constexpr char kIndexMagic[8] = {'V', 'X', 'B', 'I', 'N', 'D', 'E', 'X'};
inline constexpr uint32_t kIndexVersion = 1;

struct IndexHeader {
  char magic[8];
  uint32_t version;
  uint32_t levelCount;
  uint32_t brickSize;
  uint32_t valueType;
  uint64_t bricksFileSize;
  uint64_t recordCount;
  uint32_t bodyCrc32;
  uint32_t headerCrc32;
  uint8_t reserved[16];
};
static_assert(sizeof(IndexHeader) == 64);

struct LevelEntry {
  int64_t dims[3];
  uint32_t bricks[3];
  uint32_t reserved;
  uint64_t firstRecord;
};
static_assert(sizeof(LevelEntry) == 48);

struct BrickRecord {
  uint64_t offset;
  uint32_t compressedSize;
  uint32_t flags;
  float min;
  float max;
  uint64_t reserved;
};
static_assert(sizeof(BrickRecord) == 32);

/// Largest brick size a store may use; bounds what a corrupt index can make a reader allocate.
inline constexpr uint32_t kMaxBrickSize = 256;
/// Largest number of LOD levels (a 2^40-voxel axis would need 41).
inline constexpr uint32_t kMaxLevels = 48;

}  // namespace voxbrick::store
