// writeMeshStore: check the mesh and topology, sort the tets in Z-order, cut them into chunks, write the blocks, the
// index and mesh.json into a directory beside the store, then swap it into place.
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

#include "common/AtomicReplace.h"
#include "common/Checksum.h"
#include "mesh/MeshMeta.h"
#include "mesh/MeshStore.h"

namespace voxbrick::mesh {
namespace fs = std::filesystem;
namespace {

/// Chunks encoded in parallel before being appended in order: bounds the compressed bytes held at once while
/// keeping the file's bytes independent of the thread count.
constexpr size_t kChunkBatch = 64;

void checkOptions(const MeshStoreOptions& options) {
  if (options.tetsPerChunk < 1 || options.tetsPerChunk > kMaxTetsPerChunk)
    throw MeshError("writeMeshStore: tetsPerChunk " + std::to_string(options.tetsPerChunk) + " is outside [1, " +
                    std::to_string(kMaxTetsPerChunk) + "]");
  if (options.zstdLevel < -7 || options.zstdLevel > 22)
    throw MeshError("writeMeshStore: zstd level " + std::to_string(options.zstdLevel) + " is outside [-7, 22]");
}

/// What the format promises a reader: finite values, indices in range, a symmetric adjacency.
void checkInput(const TetMesh& mesh, const Topology& topology) {
  const std::string where = "writeMeshStore: ";
  if (mesh.tets.empty()) throw MeshError(where + "the mesh has no tetrahedra");
  if (mesh.tets.size() > kMaxTets || mesh.points.size() > kMaxVertices)
    throw MeshError(where + std::to_string(mesh.tets.size()) + " tets and " + std::to_string(mesh.points.size()) +
                    " vertices exceed the format's limits");
  if (mesh.scalars.size() != mesh.points.size())
    throw MeshError(where + std::to_string(mesh.scalars.size()) + " scalars for " + std::to_string(mesh.points.size()) +
                    " vertices");
  for (size_t v = 0; v < mesh.points.size(); ++v) {
    const glm::vec3& p = mesh.points[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(mesh.scalars[v]))
      throw MeshError(where + "vertex " + std::to_string(v) + " has a non-finite position or scalar");
  }
  for (size_t t = 0; t < mesh.tets.size(); ++t)
    for (uint32_t v : mesh.tets[t])
      if (v >= mesh.points.size())
        throw MeshError(where + "tet " + std::to_string(t) + " names vertex " + std::to_string(v) + " of " +
                        std::to_string(mesh.points.size()));
  if (topology.neighbours.size() != mesh.tets.size())
    throw MeshError(where + "the topology has " + std::to_string(topology.neighbours.size()) + " tets, the mesh " +
                    std::to_string(mesh.tets.size()));
  uint64_t open = 0;
  const auto n = static_cast<int64_t>(mesh.tets.size());
  for (int64_t t = 0; t < n; ++t)
    for (int f = 0; f < 4; ++f) {
      const int32_t u = topology.neighbours[size_t(t)][size_t(f)];
      if (u == Topology::kBoundary) {
        ++open;
        continue;
      }
      const auto& back = u >= 0 && u < n ? topology.neighbours[size_t(u)] : std::array<int32_t, 4>{};
      if (u < 0 || u >= n || std::find(back.begin(), back.end(), int32_t(t)) == back.end())
        throw MeshError(where + "tet " + std::to_string(t) + " face " + std::to_string(f) + ": neighbour " +
                        std::to_string(u) + " is out of range or does not name it back");
    }
  if (open != topology.boundary.size())
    throw MeshError(where + "the topology lists " + std::to_string(topology.boundary.size()) +
                    " boundary faces but its neighbours leave " + std::to_string(open) + " faces open");
}

/// Spreads the low 21 bits of v to every third bit.
uint64_t spreadBits(uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

/// The tets' order in the store: by the Morton code of the centroid, 21 bits an axis over the mesh bounds, ties
/// by input index so that the order (and the file) is the same on every run.
std::vector<uint32_t> mortonOrder(const TetMesh& mesh) {
  const auto [lo, hi] = mesh.bounds();
  const glm::vec3 extent = hi - lo;
  const float cells = float(1 << 21);
  std::vector<std::pair<uint64_t, uint32_t>> keys(mesh.tets.size());
  tbb::parallel_for(size_t{0}, keys.size(), [&](size_t t) {
    const Tet& tet = mesh.tets[t];
    const glm::vec3 c = 0.25f * (mesh.points[tet[0]] + mesh.points[tet[1]] + mesh.points[tet[2]] + mesh.points[tet[3]]);
    uint64_t code = 0;
    for (int a = 0; a < 3; ++a) {
      const float unit = extent[a] > 0 ? (c[a] - lo[a]) / extent[a] : 0.0f;
      const auto q = static_cast<uint64_t>(std::clamp(unit * cells, 0.0f, cells - 1.0f));
      code |= spreadBits(q) << a;
    }
    keys[t] = {code, uint32_t(t)};
  });
  tbb::parallel_sort(keys.begin(), keys.end());
  std::vector<uint32_t> order(keys.size());
  for (size_t i = 0; i < keys.size(); ++i) order[i] = keys[i].second;
  return order;
}

/// One chunk ready to append: its record (block offsets filled in when written) and its encoded blocks.
struct EncodedChunk {
  MeshChunkRecord record{};
  std::vector<char> tets, neighbours;
  std::vector<std::pair<uint32_t, uint32_t>> boundary;  // (new tet index, face)
};

EncodedChunk encodeChunk(const TetMesh& mesh, const Topology& topology, const std::vector<uint32_t>& order,
                         const std::vector<uint32_t>& newIndex, uint64_t first, uint64_t count, int level) {
  EncodedChunk out;
  std::vector<Tet> tets(count);
  std::vector<std::array<int32_t, 4>> neighbours(count);
  glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-std::numeric_limits<float>::infinity());
  float smin = std::numeric_limits<float>::infinity(), smax = -smin;
  for (uint64_t i = 0; i < count; ++i) {
    const uint32_t old = order[first + i];
    tets[i] = mesh.tets[old];
    for (int f = 0; f < 4; ++f) {
      const uint32_t v = tets[i][size_t(f)];
      lo = glm::min(lo, mesh.points[v]);
      hi = glm::max(hi, mesh.points[v]);
      smin = std::min(smin, mesh.scalars[v]);
      smax = std::max(smax, mesh.scalars[v]);
      const int32_t u = topology.neighbours[old][size_t(f)];
      neighbours[i][size_t(f)] = u == Topology::kBoundary ? Topology::kBoundary : int32_t(newIndex[size_t(u)]);
      if (u == Topology::kBoundary) out.boundary.emplace_back(uint32_t(first + i), uint32_t(f));
    }
  }
  MeshChunkRecord& r = out.record;
  r.firstTet = first;
  r.tetCount = uint32_t(count);
  std::memcpy(r.boundsMin, &lo[0], sizeof r.boundsMin);
  std::memcpy(r.boundsMax, &hi[0], sizeof r.boundsMax);
  r.scalarMin = smin;
  r.scalarMax = smax;
  out.tets = encodeBlock(tets.data(), tets.size() * sizeof(Tet), level);
  out.neighbours = encodeBlock(neighbours.data(), neighbours.size() * sizeof(neighbours[0]), level);
  return out;
}

void report(const MeshStoreOptions& options, const char* stage, uint64_t done = 1, uint64_t total = 1) {
  if (options.progress) options.progress(MeshWriteProgress{stage, done, total});
}

/// An existing `dir` is replaced only with overwrite (--force), and only if it is a mesh store.
void checkOutput(const fs::path& dir, const MeshStoreOptions& options) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return;
  if (!options.overwrite) throw MeshError(dir.string() + ": already exists (use --force to replace it)");
  if (!looksLikeMeshStore(dir))
    throw MeshError(dir.string() + ": exists and is not a voxbrick mesh store; refusing to replace it");
}

/// What the store holds, as far as the mesh, its order and the options tell before anything is written.
MeshStoreInfo describeStore(const TetMesh& mesh, const std::vector<uint32_t>& order, uint64_t chunkCount,
                            const MeshStoreOptions& options) {
  MeshStoreInfo info;
  info.field = mesh.field;
  info.source = options.source;
  info.vertexCount = mesh.points.size();
  info.tetCount = mesh.tets.size();
  info.chunkCount = uint32_t(chunkCount);
  info.tetsPerChunk = options.tetsPerChunk;
  info.zstdLevel = options.zstdLevel;
  std::tie(info.boundsMin, info.boundsMax) = mesh.bounds();
  std::tie(info.scalarMin, info.scalarMax) = mesh.scalarRange();
  EdgeLengths edges;  // in the store's order, as a reader summing chunk by chunk would
  for (const uint32_t t : order) edges.add(mesh.points, mesh.tets[t]);
  info.meanEdgeLength = edges.mean();
  info.longestEdge = edges.longest;
  return info;
}

/// The chunks, encoded in parallel batches and appended to `data` in order; returns their records and adds their
/// boundary faces to `boundary`.
std::vector<MeshChunkRecord> appendChunks(const TetMesh& mesh, const Topology& topology,
                                          const std::vector<uint32_t>& order, uint64_t chunkCount,
                                          const MeshStoreOptions& options, common::OutputFile& data,
                                          std::vector<std::pair<uint32_t, uint32_t>>& boundary) {
  std::vector<uint32_t> newIndex(order.size());
  for (size_t i = 0; i < order.size(); ++i) newIndex[order[i]] = uint32_t(i);
  // Chunk c holds sorted tets [c n / k, (c + 1) n / k): sizes differ by at most one, so no chunk is a tiny remainder.
  const uint64_t tetCount = mesh.tets.size();
  std::vector<MeshChunkRecord> records(chunkCount);
  auto chunkStart = [&](uint64_t c) { return c * tetCount / chunkCount; };
  for (uint64_t batch = 0; batch < chunkCount; batch += kChunkBatch) {
    const uint64_t end = std::min<uint64_t>(chunkCount, batch + kChunkBatch);
    std::vector<EncodedChunk> encoded(end - batch);
    tbb::parallel_for(batch, end, [&](uint64_t c) {
      const uint64_t first = chunkStart(c);
      encoded[c - batch] =
          encodeChunk(mesh, topology, order, newIndex, first, chunkStart(c + 1) - first, options.zstdLevel);
    });
    for (uint64_t c = batch; c < end; ++c) {
      EncodedChunk& e = encoded[c - batch];
      const uint64_t rawBytes = uint64_t(e.record.tetCount) * 16;
      e.record.tets = appendBlock(data, e.tets, rawBytes);
      e.record.neighbours = appendBlock(data, e.neighbours, rawBytes);
      records[c] = e.record;
      boundary.insert(boundary.end(), e.boundary.begin(), e.boundary.end());
      report(options, "chunks", c + 1, chunkCount);
    }
  }
  return records;
}

/// data.bin at `path`: the points, the scalars, the chunks and the boundary faces. Fills `header`'s block
/// references and data size and `info`'s boundary face count; returns the chunk records.
std::vector<MeshChunkRecord> writeData(const TetMesh& mesh, const Topology& topology,
                                       const std::vector<uint32_t>& order, const fs::path& path,
                                       const MeshStoreOptions& options, MeshIndexHeader& header, MeshStoreInfo& info) {
  common::OutputFile data(path, throwMeshError);
  const size_t pointBytes = mesh.points.size() * sizeof(glm::vec3);
  static_assert(sizeof(glm::vec3) == 12);
  header.points = appendBlock(data, encodeBlock(mesh.points.data(), pointBytes, options.zstdLevel), pointBytes);
  report(options, "points");
  const size_t scalarBytes = mesh.scalars.size() * sizeof(float);
  header.scalars = appendBlock(data, encodeBlock(mesh.scalars.data(), scalarBytes, options.zstdLevel), scalarBytes);
  report(options, "scalars");
  std::vector<std::pair<uint32_t, uint32_t>> boundary;
  std::vector<MeshChunkRecord> records = appendChunks(mesh, topology, order, info.chunkCount, options, data, boundary);
  info.boundaryFaceCount = boundary.size();
  const size_t boundaryBytes = boundary.size() * 8;
  static_assert(sizeof(boundary[0]) == 8);
  header.boundary = appendBlock(data, encodeBlock(boundary.data(), boundaryBytes, options.zstdLevel), boundaryBytes);
  report(options, "boundary");
  header.dataFileSize = data.size();
  data.close();
  return records;
}

/// index.bin at `path`: `header` completed from `info` and checksummed, then the chunk records; returns its size.
uint64_t writeIndex(const fs::path& path, MeshIndexHeader header, const MeshStoreInfo& info,
                    const std::vector<MeshChunkRecord>& records) {
  header.chunkCount = info.chunkCount;
  header.vertexCount = info.vertexCount;
  header.tetCount = info.tetCount;
  header.boundaryFaceCount = info.boundaryFaceCount;
  std::memcpy(header.boundsMin, &info.boundsMin[0], sizeof header.boundsMin);
  std::memcpy(header.boundsMax, &info.boundsMax[0], sizeof header.boundsMax);
  header.scalarMin = info.scalarMin;
  header.scalarMax = info.scalarMax;
  header.tetsPerChunk = info.tetsPerChunk;
  header.bodyCrc32 = common::crc32Of(records.data(), records.size() * sizeof(MeshChunkRecord));
  header.headerCrc32 = common::crc32Of(&header, offsetof(MeshIndexHeader, headerCrc32));
  common::OutputFile index(path, throwMeshError);
  index.append(&header, sizeof header);
  index.append(records.data(), records.size() * sizeof(MeshChunkRecord));
  index.close();
  return index.size();
}

/// The store's three files into the empty directory `dir`; completes `info` with what writing them found.
void writeStoreFiles(const TetMesh& mesh, const Topology& topology, const std::vector<uint32_t>& order,
                     const fs::path& dir, const MeshStoreOptions& options, MeshStoreInfo& info) {
  MeshIndexHeader header{};
  std::memcpy(header.magic, kMeshIndexMagic, sizeof header.magic);
  header.version = kMeshIndexVersion;
  const std::vector<MeshChunkRecord> records =
      writeData(mesh, topology, order, dir / kMeshDataFile, options, header, info);
  info.bytesStored = header.dataFileSize + writeIndex(dir / kMeshIndexFile, header, info, records);
  report(options, "index");
  info.bytesRaw = info.vertexCount * 16 + info.tetCount * 32 + info.boundaryFaceCount * 8;
  common::OutputFile meta(dir / kMeshMetaFile, throwMeshError);
  const std::string text = meshInfoToJson(info);
  meta.append(text.data(), text.size());
  meta.close();
  report(options, "metadata");
}

}  // namespace

bool looksLikeMeshStore(const fs::path& dir) {
  std::error_code ec;
  return fs::is_directory(dir, ec) && (fs::exists(dir / kMeshMetaFile, ec) || fs::exists(dir / kMeshIndexFile, ec));
}

MeshStoreInfo writeMeshStore(const TetMesh& mesh, const Topology& topology, const fs::path& dir,
                             const MeshStoreOptions& options) {
  checkOptions(options);
  checkInput(mesh, topology);
  checkOutput(dir, options);
  const uint64_t tetCount = mesh.tets.size();
  const uint64_t chunkCount = (tetCount + options.tetsPerChunk - 1) / options.tetsPerChunk;
  if (chunkCount > kMaxChunks)
    throw MeshError("writeMeshStore: " + std::to_string(tetCount) + " tets make more than " +
                    std::to_string(kMaxChunks) + " chunks; raise tetsPerChunk");
  const std::vector<uint32_t> order = mortonOrder(mesh);
  MeshStoreInfo info = describeStore(mesh, order, chunkCount, options);
  // Written beside `dir`, then swapped in: an existing store stays at the path until the new one replaces it.
  try {
    common::replaceDirectory(dir, [&](const fs::path& staging) {
      writeStoreFiles(mesh, topology, order, staging, options, info);
      report(options, "commit");
    });
  } catch (const common::ReplaceError& e) {
    throw MeshError(e.what());
  }
  return info;
}

}  // namespace voxbrick::mesh
