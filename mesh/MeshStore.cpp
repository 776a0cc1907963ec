// The mesh store's read side: opening checks every size, count and checksum against the files before anything is
// allocated from it; chunks are checked again, index by index, when they are read.
#include "mesh/MeshStore.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <iomanip>
#include <sstream>

#include "common/Checksum.h"
#include "mesh/MeshMeta.h"

namespace voxbrick::mesh {
namespace fs = std::filesystem;
namespace {

/// mesh.json is a few hundred bytes; anything near this is not ours.
constexpr uint64_t kMaxMetaBytes = uint64_t{1} << 20;

std::string readMeta(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw MeshError(path.string() + ": missing (not a complete mesh store)");
  MeshInputFile file(path);
  if (file.size() > kMaxMetaBytes)
    throw MeshError(path.string() + ": " + std::to_string(file.size()) + " bytes, larger than any store writes");
  std::string text(file.size(), '\0');
  file.readAt(0, text.data(), text.size());
  return text;
}

glm::vec3 toVec(const float (&v)[3]) { return {v[0], v[1], v[2]}; }

bool finiteRange(float lo, float hi) { return std::isfinite(lo) && std::isfinite(hi) && lo <= hi; }

bool finiteBox(const glm::vec3& lo, const glm::vec3& hi) {
  return finiteRange(lo.x, hi.x) && finiteRange(lo.y, hi.y) && finiteRange(lo.z, hi.z);
}

bool inside(const glm::vec3& lo, const glm::vec3& hi, const glm::vec3& outerLo, const glm::vec3& outerHi) {
  return glm::all(glm::greaterThanEqual(lo, outerLo)) && glm::all(glm::lessThanEqual(hi, outerHi));
}

/// The header's fields that need no other file: magic, version, checksum, reserved bytes, counts within limits.
void checkHeader(const MeshIndexHeader& h, const std::string& where) {
  if (h.headerCrc32 != common::crc32Of(&h, offsetof(MeshIndexHeader, headerCrc32)))
    throw MeshError(where + ": header checksum mismatch (corrupt index)");
  if (h.reserved != 0) throw MeshError(where + ": reserved header field is not zero");
  auto count = [&](const char* what, uint64_t value, uint64_t lo, uint64_t hi) {
    if (value < lo || value > hi)
      throw MeshError(where + ": " + what + " " + std::to_string(value) + " is outside [" + std::to_string(lo) + ", " +
                      std::to_string(hi) + "]");
  };
  count("vertex count", h.vertexCount, 1, kMaxVertices);
  count("tet count", h.tetCount, 1, kMaxTets);
  count("chunk count", h.chunkCount, 1, std::min<uint64_t>(kMaxChunks, h.tetCount));
  count("boundary face count", h.boundaryFaceCount, 0, 4 * h.tetCount);
  count("tetsPerChunk", h.tetsPerChunk, 1, kMaxTetsPerChunk);
  if (!finiteBox(toVec(h.boundsMin), toVec(h.boundsMax)) || !finiteRange(h.scalarMin, h.scalarMax))
    throw MeshError(where + ": bounds or scalar range not finite and ordered");
}

/// The index's header: magic and version first (a later version may lay out the rest differently), then the
/// fields checkHeader checks.
MeshIndexHeader readHeader(const MeshInputFile& index, const std::string& indexName) {
  MeshIndexHeader h{};
  if (index.size() < offsetof(MeshIndexHeader, chunkCount))
    throw MeshError(indexName + ": " + std::to_string(index.size()) + " bytes, truncated header");
  index.readAt(0, &h, offsetof(MeshIndexHeader, chunkCount));
  if (std::memcmp(h.magic, kMeshIndexMagic, sizeof h.magic) != 0) throw MeshError(indexName + ": bad magic");
  if (h.version != kMeshIndexVersion)
    throw MeshError(indexName + ": index version " + std::to_string(h.version) + ", this build reads " +
                    std::to_string(kMeshIndexVersion));
  if (index.size() < sizeof h)
    throw MeshError(indexName + ": " + std::to_string(index.size()) + " bytes, truncated header");
  index.readAt(0, &h, sizeof h);
  checkHeader(h, indexName);
  return h;
}

/// The chunk table after the header, checked against the index's size, mesh.json's counts and the checksum.
std::vector<MeshChunkRecord> readRecords(const MeshInputFile& index, const MeshIndexHeader& h,
                                         const MeshStoreInfo& meta, const std::string& metaName) {
  const std::string indexName = index.path().string();
  const uint64_t expected = sizeof h + uint64_t(h.chunkCount) * sizeof(MeshChunkRecord);
  if (index.size() != expected)
    throw MeshError(indexName + ": " + std::to_string(index.size()) + " bytes, " + std::to_string(h.chunkCount) +
                    " chunks need " + std::to_string(expected) + " (truncated or corrupt)");
  if (meta.vertexCount != h.vertexCount || meta.tetCount != h.tetCount || meta.chunkCount != h.chunkCount ||
      meta.boundaryFaceCount != h.boundaryFaceCount || meta.tetsPerChunk != h.tetsPerChunk)
    throw MeshError(indexName + ": counts do not match " + metaName);
  std::vector<MeshChunkRecord> records(h.chunkCount);
  index.readAt(sizeof h, records.data(), records.size() * sizeof(MeshChunkRecord));
  if (common::crc32Of(records.data(), records.size() * sizeof(MeshChunkRecord)) != h.bodyCrc32)
    throw MeshError(indexName + ": chunk table checksum mismatch (corrupt index)");
  return records;
}

/// The chunks the records describe, each checked to follow the one before, to lie within the mesh's bounds and
/// range and to name blocks inside the data file of `dataSize` bytes.
std::vector<ChunkInfo> chunksOf(const std::vector<MeshChunkRecord>& records, const MeshIndexHeader& h,
                                uint64_t dataSize, const std::string& indexName) {
  const glm::vec3 lo = toVec(h.boundsMin), hi = toVec(h.boundsMax);
  uint64_t next = 0;
  std::vector<ChunkInfo> chunks(h.chunkCount);
  for (uint32_t c = 0; c < h.chunkCount; ++c) {
    const MeshChunkRecord& r = records[c];
    const std::string what = "chunk " + std::to_string(c);
    if (r.firstTet != next || r.tetCount < 1 || r.tetCount > kMaxTetsPerChunk || r.tetCount > h.tetCount - next ||
        r.reserved != 0)
      throw MeshError(indexName + ": " + what + ": tets [" + std::to_string(r.firstTet) + ", +" +
                      std::to_string(r.tetCount) + ") do not follow the chunk before (expected first " +
                      std::to_string(next) + ")");
    next += r.tetCount;
    const glm::vec3 clo = toVec(r.boundsMin), chi = toVec(r.boundsMax);
    if (!finiteBox(clo, chi) || !inside(clo, chi, lo, hi) || !finiteRange(r.scalarMin, r.scalarMax) ||
        r.scalarMin < h.scalarMin || r.scalarMax > h.scalarMax)
      throw MeshError(indexName + ": " + what + ": bounds or scalar range outside the mesh's");
    checkBlockRef(r.tets, dataSize, uint64_t(r.tetCount) * 16, indexName, what + " tets");
    checkBlockRef(r.neighbours, dataSize, uint64_t(r.tetCount) * 16, indexName, what + " neighbours");
    chunks[c] = ChunkInfo{r.firstTet,
                          r.tetCount,
                          clo,
                          chi,
                          r.scalarMin,
                          r.scalarMax,
                          r.tets.compressedSize + r.neighbours.compressedSize};
  }
  if (next != h.tetCount)
    throw MeshError(indexName + ": chunks hold " + std::to_string(next) + " tets, the header says " +
                    std::to_string(h.tetCount));
  return chunks;
}

/// The points and scalars, checked finite and to span exactly the index's bounds and range (the writer takes both
/// from TetMesh::bounds() and scalarRange(), so they match exactly). Every count is bounded by the file sizes by
/// now, so the arrays can be sized from them.
void readVertices(const MeshInputFile& data, const MeshIndexHeader& h, std::vector<glm::vec3>& points,
                  std::vector<float>& scalars) {
  points.resize(h.vertexCount);
  data.readBlock(h.points, points.data(), h.vertexCount * 12, "points");
  scalars.resize(h.vertexCount);
  data.readBlock(h.scalars, scalars.data(), h.vertexCount * 4, "scalars");
  glm::vec3 plo = points[0], phi = plo;
  float smin = scalars[0], smax = smin;
  for (size_t v = 0; v < points.size(); ++v) {
    const glm::vec3& p = points[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(scalars[v]))
      throw MeshError(data.path().string() + ": vertex " + std::to_string(v) + " is not finite");
    plo = glm::min(plo, points[v]);
    phi = glm::max(phi, points[v]);
    smin = std::min(smin, scalars[v]);
    smax = std::max(smax, scalars[v]);
  }
  if (plo != toVec(h.boundsMin) || phi != toVec(h.boundsMax) || smin != h.scalarMin || smax != h.scalarMax)
    throw MeshError(data.path().string() + ": points or scalars do not match the index's bounds and range");
}

}  // namespace

MeshStore MeshStore::open(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw MeshError(dir.string() + ": not a mesh store directory");
  MeshStore store;
  store.mPath = dir;
  const fs::path metaPath = dir / kMeshMetaFile;
  const MeshStoreInfo meta = meshInfoFromJson(readMeta(metaPath), metaPath.string());

  const fs::path indexPath = dir / kMeshIndexFile;
  const std::string indexName = indexPath.string();
  MeshInputFile index(indexPath);
  const MeshIndexHeader h = readHeader(index, indexName);
  store.mRecords = readRecords(index, h, meta, metaPath.string());

  store.mData = MeshInputFile(dir / kMeshDataFile);
  const uint64_t dataSize = store.mData.size();
  if (dataSize != h.dataFileSize)
    throw MeshError(store.mData.path().string() + ": " + std::to_string(dataSize) + " bytes, the index expects " +
                    std::to_string(h.dataFileSize) + " (truncated or replaced)");
  checkBlockRef(h.points, dataSize, h.vertexCount * 12, indexName, "points");
  checkBlockRef(h.scalars, dataSize, h.vertexCount * 4, indexName, "scalars");
  checkBlockRef(h.boundary, dataSize, h.boundaryFaceCount * 8, indexName, "boundary");
  store.mBoundaryBlock = h.boundary;
  store.mChunks = chunksOf(store.mRecords, h, dataSize, indexName);
  readVertices(store.mData, h, store.mPoints, store.mScalars);

  store.mInfo = meta;
  store.mInfo.boundsMin = toVec(h.boundsMin);
  store.mInfo.boundsMax = toVec(h.boundsMax);
  store.mInfo.scalarMin = h.scalarMin;
  store.mInfo.scalarMax = h.scalarMax;
  store.mInfo.bytesRaw = h.vertexCount * 16 + h.tetCount * 32 + h.boundaryFaceCount * 8;
  store.mInfo.bytesStored = dataSize + index.size();
  return store;
}

const ChunkInfo& MeshStore::chunk(size_t i) const {
  if (i >= mChunks.size())
    throw MeshError(mPath.string() + ": chunk " + std::to_string(i) + " of " + std::to_string(mChunks.size()));
  return mChunks[i];
}

size_t MeshStore::chunkOf(uint64_t tet) const {
  if (tet >= mInfo.tetCount)
    throw MeshError(mPath.string() + ": tet " + std::to_string(tet) + " of " + std::to_string(mInfo.tetCount));
  // Chunks follow one another from tet 0 (checked at open): the last one starting at or before `tet`.
  const auto after = std::upper_bound(mChunks.begin(), mChunks.end(), tet,
                                      [](uint64_t t, const ChunkInfo& c) { return t < c.firstTet; });
  return size_t(after - mChunks.begin()) - 1;
}

MeshChunk MeshStore::readChunk(size_t i) const {
  const ChunkInfo& c = chunk(i);
  const MeshChunkRecord& r = mRecords[i];
  const std::string what = "chunk " + std::to_string(i);
  MeshChunk out;
  out.firstTet = c.firstTet;
  out.tets.resize(c.tetCount);
  out.neighbours.resize(c.tetCount);
  mData.readBlock(r.tets, out.tets.data(), uint64_t(c.tetCount) * 16, what + " tets");
  mData.readBlock(r.neighbours, out.neighbours.data(), uint64_t(c.tetCount) * 16, what + " neighbours");
  const uint64_t vertices = mPoints.size();
  const auto tets = static_cast<int64_t>(mInfo.tetCount);
  for (uint32_t t = 0; t < c.tetCount; ++t)
    for (int f = 0; f < 4; ++f) {
      const uint32_t v = out.tets[t][size_t(f)];
      const int32_t u = out.neighbours[t][size_t(f)];
      if (v >= vertices)
        throw MeshError(mData.path().string() + ": " + what + ": tet " + std::to_string(c.firstTet + t) +
                        " names vertex " + std::to_string(v) + " of " + std::to_string(vertices));
      if (u != Topology::kBoundary && (u < 0 || u >= tets))
        throw MeshError(mData.path().string() + ": " + what + ": tet " + std::to_string(c.firstTet + t) +
                        " has neighbour " + std::to_string(u) + " of " + std::to_string(tets));
    }
  return out;
}

std::vector<BoundaryFace> MeshStore::boundary() const {
  const uint64_t count = mInfo.boundaryFaceCount;
  std::vector<std::array<uint32_t, 2>> raw(count);
  mData.readBlock(mBoundaryBlock, raw.data(), count * 8, "boundary");
  std::vector<BoundaryFace> faces(count);
  uint64_t previous = 0;
  for (uint64_t i = 0; i < count; ++i) {
    const auto [tet, face] = raw[i];
    // Strictly increasing tet * 4 + face: the documented order, and no face twice.
    const uint64_t key = uint64_t(tet) * 4 + face;
    if (tet >= mInfo.tetCount || face > 3 || (i > 0 && key <= previous))
      throw MeshError(mData.path().string() + ": boundary face " + std::to_string(i) + " (tet " + std::to_string(tet) +
                      ", face " + std::to_string(face) + ") is out of range or out of order");
    previous = key;
    faces[i] = BoundaryFace{tet, uint8_t(face)};
  }
  return faces;
}

TetMesh MeshStore::readAll() const {
  TetMesh mesh;
  mesh.points = mPoints;
  mesh.scalars = mScalars;
  mesh.field = mInfo.field;
  mesh.tets.resize(mInfo.tetCount);
  tbb::parallel_for(size_t{0}, mChunks.size(), [&](size_t i) {
    const MeshChunk c = readChunk(i);
    std::copy(c.tets.begin(), c.tets.end(), mesh.tets.begin() + std::ptrdiff_t(c.firstTet));
  });
  return mesh;
}

std::pair<double, double> MeshStore::edgeLengths() const {
  if (mInfo.meanEdgeLength > 0) return {mInfo.meanEdgeLength, mInfo.longestEdge};
  EdgeLengths edges;  // chunk by chunk in the store's order, as the writer sums them
  for (size_t i = 0; i < mChunks.size(); ++i)
    for (const Tet& tet : readChunk(i).tets) edges.add(mPoints, tet);
  return {edges.mean(), edges.longest};
}

Topology MeshStore::readTopology() const {
  Topology topology;
  topology.neighbours.resize(mInfo.tetCount);
  tbb::parallel_for(size_t{0}, mChunks.size(), [&](size_t i) {
    const MeshChunk c = readChunk(i);
    std::copy(c.neighbours.begin(), c.neighbours.end(), topology.neighbours.begin() + std::ptrdiff_t(c.firstTet));
  });
  topology.boundary = boundary();
  // The list must be exactly the open faces, in order; both are sorted, so one walk compares them.
  size_t next = 0;
  for (size_t t = 0; t < topology.neighbours.size(); ++t)
    for (uint8_t f = 0; f < 4; ++f)
      if (topology.neighbours[t][f] == Topology::kBoundary) {
        if (next >= topology.boundary.size() || !(topology.boundary[next] == BoundaryFace{uint32_t(t), f}))
          throw MeshError(mData.path().string() + ": the boundary block does not list the open face " +
                          std::to_string(f) + " of tet " + std::to_string(t));
        ++next;
      }
  if (next != topology.boundary.size())
    throw MeshError(mData.path().string() + ": the boundary block lists faces that have neighbours");
  return topology;
}

std::string describeMeshStore(const MeshStore& store) {
  const MeshStoreInfo& i = store.info();
  std::ostringstream s;
  auto vec = [&](const glm::vec3& v) { s << '(' << v.x << ", " << v.y << ", " << v.z << ')'; };
  s << "mesh store    " << store.path().string() << '\n';
  if (!i.source.empty()) s << "source        " << i.source << '\n';
  s << "field         " << (i.field.empty() ? "(unnamed)" : i.field) << ", range [" << i.scalarMin << ", "
    << i.scalarMax << "]\n";
  s << "vertices      " << i.vertexCount << '\n';
  s << "tets          " << i.tetCount << " in " << i.chunkCount << " chunks of about " << i.tetsPerChunk << '\n';
  s << "boundary      " << i.boundaryFaceCount << " faces\n";
  s << "bounds        ";
  vec(i.boundsMin);
  s << " to ";
  vec(i.boundsMax);
  s << '\n';
  const double ratio = i.bytesStored > 0 ? double(i.bytesRaw) / double(i.bytesStored) : 0.0;
  s << std::fixed << std::setprecision(2);
  s << "bytes         " << i.bytesRaw << " raw, " << i.bytesStored << " stored (zstd level " << i.zstdLevel << ", "
    << ratio << ":1), " << double(i.bytesStored) / double(std::max<uint64_t>(1, i.tetCount)) << " a tet\n";
  return s.str();
}

}  // namespace voxbrick::mesh
