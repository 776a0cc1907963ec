// On-disk layout of a mesh store's binary index (mesh-index.bin). Little-endian; pinned by
// tests/mesh/test_mesh_store.cpp. mesh/FORMAT.md says the same in prose.
//
// A mesh store is a directory, written by writeMeshStore (mesh/MeshStore.h) into a sibling and renamed into place:
//   mesh.json        metadata: field, source, counts, bounds, scalar range, bytes (written last)
//   mesh-index.bin   MeshIndexHeader, then chunkCount MeshChunkRecord
//   mesh-data.bin    zstd frames at the offsets the index gives; no header, no padding
//
// Tets are sorted by the Morton (Z-order) code of their centroid in the mesh bounds and cut into chunks of
// consecutive tets, so a chunk is a compact piece of space: its bounds and scalar range let a renderer cull it,
// skip it when the transfer function maps its range to zero opacity, and page it alone.
//
// Every block is an array of 4-byte little-endian values whose bytes are shuffled into planes (byte 0 of every
// value, then byte 1, ...) and compressed as one zstd frame (with its content size). Blocks:
//   points       vertexCount x (x, y, z) float32, in the input's vertex order
//   scalars      vertexCount x float32
//   boundary     boundaryFaceCount x (tet uint32, face uint32): every face whose neighbour is -1, in tet then face
//                order (tet indices are the sorted order)
//   chunk tets   tetCount x 4 uint32 vertex indices
//   chunk nbrs   tetCount x 4 int32: the global (sorted) index of the tet across face f (opposite vertex f), or -1
//
// mesh-index.bin:
//   offset  size  MeshIndexHeader (192 bytes)
//        0     8  magic "VXMESHIX"
//        8     4  version (kMeshIndexVersion)
//       12     4  chunkCount
//       16     8  vertexCount
//       24     8  tetCount
//       32     8  boundaryFaceCount
//       40     8  dataFileSize (must equal the size of mesh-data.bin)
//       48    12  boundsMin x, y, z (float32): the bounds of every vertex
//       60    12  boundsMax x, y, z
//       72     4  scalarMin (float32)
//       76     4  scalarMax
//       80    32  points   BlockRef
//      112    32  scalars  BlockRef
//      144    32  boundary BlockRef
//      176     4  tetsPerChunk (the option the store was written with)
//      180     4  reserved, zero
//      184     4  bodyCrc32 (CRC-32 of every byte after the header)
//      188     4  headerCrc32 (CRC-32 of bytes 0..187)
//   then chunk c, MeshChunkRecord (112 bytes), at 192 + 112 c:
//        0     8  firstTet (chunk 0: 0; chunk c + 1: firstTet + tetCount of chunk c)
//        8     4  tetCount (>= 1)
//       12     4  reserved, zero
//       16    12  boundsMin x, y, z (float32): the bounds of the chunk's tets' vertices
//       28    12  boundsMax
//       40     4  scalarMin (float32): over the chunk's tets' vertices
//       44     4  scalarMax
//       48    32  tets BlockRef
//       80    32  neighbours BlockRef
//   BlockRef (32 bytes):
//        0     8  offset in mesh-data.bin
//        8     8  compressedSize
//       16     8  rawSize (bytes after decompression: the count times the value size above)
//       24     4  crc32 (CRC-32 of the compressed bytes, checked before decompression)
//       28     4  reserved, zero
#pragma once

#include <bit>
#include <cstdint>

namespace voxbrick::mesh {

static_assert(std::endian::native == std::endian::little, "the mesh store is read and written in host order");

inline constexpr char kMeshIndexMagic[8] = {'V', 'X', 'M', 'E', 'S', 'H', 'I', 'X'};
inline constexpr uint32_t kMeshIndexVersion = 1;

inline constexpr const char* kMeshMetaFile = "mesh.json";
inline constexpr const char* kMeshIndexFile = "mesh-index.bin";
inline constexpr const char* kMeshDataFile = "mesh-data.bin";

struct BlockRef {
  uint64_t offset;
  uint64_t compressedSize;
  uint64_t rawSize;
  uint32_t crc32;
  uint32_t reserved;
};
static_assert(sizeof(BlockRef) == 32);

struct MeshIndexHeader {
  char magic[8];
  uint32_t version;
  uint32_t chunkCount;
  uint64_t vertexCount;
  uint64_t tetCount;
  uint64_t boundaryFaceCount;
  uint64_t dataFileSize;
  float boundsMin[3];
  float boundsMax[3];
  float scalarMin;
  float scalarMax;
  BlockRef points;
  BlockRef scalars;
  BlockRef boundary;
  uint32_t tetsPerChunk;
  uint32_t reserved;
  uint32_t bodyCrc32;
  uint32_t headerCrc32;
};
static_assert(sizeof(MeshIndexHeader) == 192);

struct MeshChunkRecord {
  uint64_t firstTet;
  uint32_t tetCount;
  uint32_t reserved;
  float boundsMin[3];
  float boundsMax[3];
  float scalarMin;
  float scalarMax;
  BlockRef tets;
  BlockRef neighbours;
};
static_assert(sizeof(MeshChunkRecord) == 112);

/// Limits a reader checks before it sizes anything from the index, and a writer before it writes.
/// Vertex indices are uint32 and neighbour indices int32 (with -1 for the boundary).
inline constexpr uint64_t kMaxVertices = uint64_t{1} << 32;
inline constexpr uint64_t kMaxTets = (uint64_t{1} << 31) - 1;
inline constexpr uint32_t kMaxChunks = uint32_t{1} << 24;
/// A chunk decodes to 32 bytes a tet (indices and neighbours): 4 Mi tets is 128 MiB.
inline constexpr uint32_t kMaxTetsPerChunk = uint32_t{1} << 22;
/// No zstd frame decodes to more than this many times its size (a 3-byte block header stands for at most a
/// 128 KiB block), so a block claiming more is corrupt and is refused before its buffer is allocated.
inline constexpr uint64_t kMaxZstdRatio = uint64_t{1} << 16;

}  // namespace voxbrick::mesh
