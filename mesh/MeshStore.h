// The mesh store: a directory `prep` writes once from a TetMesh and its Topology (tets sorted in Z-order and cut into
// spatial chunks, each zstd-compressed with its bounds and scalar range), and the read side that opens it, checks it
// and pages chunks. The byte layout is drawn in mesh/MeshFormat.h and described in mesh/FORMAT.md. No GL.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mesh/MeshBlocks.h"
#include "mesh/MeshFormat.h"
#include "mesh/TetMesh.h"
#include "mesh/Topology.h"

namespace voxbrick::mesh {

/// How far writeMeshStore has got: reported after each block it writes and once before the final rename.
struct MeshWriteProgress {
  std::string stage;   ///< "points", "scalars", "chunks", "boundary", "index", "metadata", "commit"
  uint64_t done = 0;   ///< chunks written so far for "chunks"; 1 for the other stages
  uint64_t total = 0;  ///< chunk count for "chunks"; 1 for the other stages
};

struct MeshStoreOptions {
  uint32_t tetsPerChunk = 16384;  ///< in [1, kMaxTetsPerChunk]; every chunk holds this many tets, or one fewer
  int zstdLevel = 3;              ///< in [-7, 22]
  bool overwrite = false;         ///< replace an existing mesh store at the target (never any other directory)
  std::string source;             ///< what the mesh was read from, recorded for `info`
  /// Called as the write advances. An exception it throws aborts the write like any failure: the staging directory
  /// is removed and the target is left as it was (tests inject failures this way).
  std::function<void(const MeshWriteProgress&)> progress;
};

/// What `info` says about a store: the counts, ranges and sizes, from its index and mesh.json.
struct MeshStoreInfo {
  std::string field;   ///< the scalar's name
  std::string source;  ///< what the mesh was read from ("" when unknown)
  uint64_t vertexCount = 0;
  uint64_t tetCount = 0;
  uint64_t boundaryFaceCount = 0;
  uint32_t chunkCount = 0;
  uint32_t tetsPerChunk = 0;
  int zstdLevel = 0;
  glm::vec3 boundsMin{0.0f}, boundsMax{0.0f};  ///< of every vertex
  float scalarMin = 0.0f, scalarMax = 0.0f;
  /// Over every tet's six edges in the store's order (EdgeLengths): the mean and the longest. 0 in a store written
  /// before mesh.json recorded them; MeshStore::edgeLengths() then measures them.
  double meanEdgeLength = 0, longestEdge = 0;
  uint64_t bytesRaw = 0;     ///< every block decoded: 16 a vertex, 32 a tet, 8 a boundary face
  uint64_t bytesStored = 0;  ///< mesh-data.bin and mesh-index.bin
};

/// A chunk as its index record gives it (no I/O).
struct ChunkInfo {
  uint64_t firstTet = 0;  ///< global index (in the store's sorted order) of its first tet
  uint32_t tetCount = 0;
  glm::vec3 boundsMin{0.0f}, boundsMax{0.0f};  ///< of its tets' vertices
  float scalarMin = 0.0f, scalarMax = 0.0f;    ///< over its tets' vertices
  uint64_t compressedBytes = 0;                ///< its two blocks on disk
};

/// One chunk, decoded: tets firstTet .. firstTet + tets.size() - 1 of the store.
struct MeshChunk {
  uint64_t firstTet = 0;
  std::vector<Tet> tets;                           ///< indices into MeshStore::points()
  std::vector<std::array<int32_t, 4>> neighbours;  ///< global tet indices, or Topology::kBoundary
};

/// Writes `mesh` and its `topology` (indexed like mesh.tets) as a mesh store at `dir`: tets sorted by the Morton code
/// of their centroid and cut into chunks, the topology renumbered to match (boundary faces are re-derived from it in
/// the new order). Written into a sibling directory and renamed into place only when complete. Throws MeshError for
/// a bad option, an inconsistent mesh or topology, an existing `dir` without `overwrite` (or that is not a mesh
/// store), or an I/O failure; `dir` is then as it was. Returns what `info` would say.
MeshStoreInfo writeMeshStore(const TetMesh& mesh, const Topology& topology, const std::filesystem::path& dir,
                             const MeshStoreOptions& options = {});

/// True when `dir` is a directory holding mesh.json or mesh-index.bin (a store, perhaps damaged).
bool looksLikeMeshStore(const std::filesystem::path& dir);

/// An opened mesh store: the index and the vertices in memory, chunks read on demand. Immutable; the const reads
/// are safe from several threads (pread on one descriptor).
class MeshStore {
 public:
  /// Opens the store at `dir`: checks mesh.json, the index (magic, version, checksums, counts within the format's
  /// limits and agreeing with mesh.json, every block inside mesh-data.bin and of the size its counts give), then
  /// reads and checks the points and scalars. Throws MeshError naming the file and what is wrong.
  static MeshStore open(const std::filesystem::path& dir);

  const std::filesystem::path& path() const { return mPath; }
  const MeshStoreInfo& info() const { return mInfo; }
  size_t chunkCount() const { return mChunks.size(); }
  /// The index record of chunk i; throws MeshError when i is out of range.
  const ChunkInfo& chunk(size_t i) const;
  /// The chunk holding tet `tet` (a global index in the store's order); throws MeshError when it is out of range.
  size_t chunkOf(uint64_t tet) const;
  /// Reads chunk i: checksums verified, vertex and neighbour indices range-checked. Throws MeshError.
  MeshChunk readChunk(size_t i) const;
  const std::vector<glm::vec3>& points() const { return mPoints; }
  const std::vector<float>& scalars() const { return mScalars; }
  /// The boundary faces, in tet then face order; throws MeshError on a corrupt block.
  std::vector<BoundaryFace> boundary() const;
  /// The whole mesh, tets in the store's order. Throws MeshError.
  TetMesh readAll() const;
  /// The whole topology, indexed like readAll().tets; checks that the boundary list matches the neighbours.
  Topology readTopology() const;
  /// The mean and longest edge length over every tet: mesh.json's, or (a store written before it recorded them)
  /// measured by reading every chunk once, one at a time. Throws MeshError.
  std::pair<double, double> edgeLengths() const;

 private:
  MeshStore() = default;

  std::filesystem::path mPath;
  MeshStoreInfo mInfo;
  std::vector<ChunkInfo> mChunks;
  std::vector<MeshChunkRecord> mRecords;
  BlockRef mBoundaryBlock{};
  std::vector<glm::vec3> mPoints;
  std::vector<float> mScalars;
  MeshInputFile mData;
};

/// A few lines for `voxbrick info`: counts, bounds, field and scalar range, chunks, bytes raw and stored, bytes a tet.
std::string describeMeshStore(const MeshStore& store);

}  // namespace voxbrick::mesh
