// Where a mesh's frames get their tets: whole, or paged by view.
#include "render/tets/TetMeshSource.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <list>
#include <mutex>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "brickstore/format/Errors.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::render {
namespace {

std::string mebibytes(size_t bytes) {
  if (bytes < (size_t(1) << 20)) return std::to_string(bytes) + " bytes";
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f MiB", double(bytes) / double(size_t(1) << 20));
  return text;
}

using Clock = std::chrono::steady_clock;

}  // namespace

struct TetMeshSource::Paged {
  /// A working set kept for later frames.
  struct Kept {
    std::vector<uint32_t> chunks;  // the chunks it holds, ascending: its key
    std::shared_ptr<const TetMeshData> data;
    size_t bytes = 0;
    uint64_t lastUse = 0;
  };
  /// Bytes of every working set alive, kept or held by a frame: each set's deleter takes its bytes off. Shared with
  /// the deleters, which may run after the source is gone.
  struct Live {
    std::atomic<size_t> bytes{0};
  };

  std::shared_ptr<const mesh::MeshStore> store;
  size_t resident = 0;
  std::shared_ptr<Live> live = std::make_shared<Live>();
  mutable std::mutex mutex;  // the fields below, and one working set built at a time
  size_t budget = 0;
  std::list<Kept> kept;
  /// Chunk sets that did not fit the budget when last tried (the newest kTooLargeKept).
  static constexpr size_t kTooLargeKept = 8;
  std::vector<std::vector<uint32_t>> tooLarge;
  uint64_t uses = 0;
  store::CacheStats counters;

  size_t available() const { return budget > resident ? budget - resident : 0; }
  /// Drops kept sets no frame holds (the kept pointer the only owner), least recently used first, until `wanted`
  /// more bytes fit beside the live ones or none is left to drop.
  void makeRoom(size_t wanted) {
    while (live->bytes + wanted > available()) {
      auto victim = kept.end();
      for (auto it = kept.begin(); it != kept.end(); ++it)
        if (it->data.use_count() == 1 && (victim == kept.end() || it->lastUse < victim->lastUse)) victim = it;
      if (victim == kept.end()) return;
      kept.erase(victim);
      ++counters.evictions;
    }
  }
  /// Makes room for `bytes` more (dropping kept sets no frame holds), or throws RenderLimitError, naming the sizes,
  /// when even that would not make room; then nothing is dropped.
  void reserve(size_t bytes, uint64_t tets, size_t chunks) {
    size_t droppable = 0;
    for (const Kept& k : kept) droppable += k.data.use_count() == 1 ? k.bytes : 0;
    const size_t held = live->bytes - droppable;  // by frames drawing now
    if (held + bytes > available())
      throw RenderLimitError(
          "tet mesh '" + store->path().filename().string() + "': this view needs " + std::to_string(chunks) +
          " of its " + std::to_string(store->chunkCount()) + " chunks (" + std::to_string(tets) + " tets), " +
          mebibytes(bytes) + " in memory, above the " + mebibytes(available()) + " its host budget of " +
          mebibytes(budget) + " leaves beside its points" +
          (held > 0 ? " and the " + mebibytes(held) + " other frames hold" : std::string()) +
          "; narrow the view, make more of the transfer function transparent, or raise the budget (render's "
          "--host-cache; a server's host_cache_mb)");
    makeRoom(bytes);
  }
  /// Reads `chunks` into a working set and keeps it (or throws as reserve() does, or CorruptStoreError).
  std::shared_ptr<const TetMeshData> build(const std::vector<uint32_t>& chunks, const TetMeshConstants& constants);
};

std::shared_ptr<const TetMeshData> TetMeshSource::Paged::build(const std::vector<uint32_t>& chunks,
                                                               const TetMeshConstants& constants) {
  const mesh::MeshStore& s = *store;
  // Where each chosen chunk's tets go in the working set (chunks keep their order, so tets keep theirs).
  std::vector<int64_t> offset(s.chunkCount(), -1);
  uint64_t tets = 0;
  for (const uint32_t c : chunks) {
    offset[c] = int64_t(tets);
    tets += s.chunk(c).tetCount;
  }
  reserve(TetMeshData::hostBytes(tets, 0, 0), tets, chunks.size());  // before reading: a bound from below
  mesh::TetMesh part;
  mesh::Topology topology;
  part.field = constants.field;
  part.tets.resize(tets);
  topology.neighbours.resize(tets);
  // A neighbour in a chunk left out becomes a boundary face of the part: a ray leaving through it has nothing more
  // to meet there (transparent or outside the view), and the ray caster looks for where it enters again.
  auto renumber = [&](int32_t neighbour) -> int32_t {
    if (neighbour == mesh::Topology::kBoundary) return neighbour;
    const size_t c = s.chunkOf(uint64_t(neighbour));
    return offset[c] < 0 ? mesh::Topology::kBoundary
                         : int32_t(offset[c] + (int64_t(neighbour) - int64_t(s.chunk(c).firstTet)));
  };
  try {
    tbb::parallel_for(size_t{0}, chunks.size(), [&](size_t i) {
      mesh::MeshChunk chunk = s.readChunk(chunks[i]);
      const auto at = std::ptrdiff_t(offset[chunks[i]]);
      std::copy(chunk.tets.begin(), chunk.tets.end(), part.tets.begin() + at);
      for (size_t t = 0; t < chunk.neighbours.size(); ++t)
        for (int f = 0; f < 4; ++f) topology.neighbours[size_t(at) + t][f] = renumber(chunk.neighbours[t][f]);
    });
  } catch (const mesh::MeshError& e) {
    // A chunk failing its checks is a corrupt store, as a corrupt brick is: a server quarantines the dataset.
    throw store::CorruptStoreError(e.what());
  }
  counters.bricksDecoded += chunks.size();
  counters.bytesDecoded += tets * 32;
  // The points the part uses, renumbered in their order.
  const std::vector<uint32_t> newIndex = mesh::keepUsedPoints(part, s.points(), s.scalars());
  const uint32_t used = uint32_t(part.points.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, part.tets.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t)
      for (uint32_t& v : part.tets[t]) v = newIndex[v];
  });
  for (uint32_t t = 0; t < tets; ++t)
    for (uint8_t f = 0; f < 4; ++f)
      if (topology.neighbours[t][f] == mesh::Topology::kBoundary) topology.boundary.push_back({t, f});
  const size_t bytes = TetMeshData::hostBytes(tets, used, topology.boundary.size());
  reserve(bytes, tets, chunks.size());
  auto* data = new TetMeshData(std::move(part), std::move(topology), constants);
  live->bytes += bytes;
  counters.peakResidentBytes = std::max(counters.peakResidentBytes, resident + live->bytes);
  ++counters.misses;
  std::shared_ptr<const TetMeshData> built(data, [live = live, bytes](const TetMeshData* d) {
    live->bytes -= bytes;
    delete d;
  });
  kept.push_back({chunks, built, bytes, ++uses});
  return built;
}

TetMeshSource::TetMeshSource(std::shared_ptr<const TetMeshData> whole, std::vector<mesh::ChunkInfo> chunks)
    : mConstants(static_cast<const TetMeshConstants&>(*whole)), mWhole(std::move(whole)), mChunks(std::move(chunks)) {}

TetMeshSource::TetMeshSource(std::shared_ptr<const mesh::MeshStore> store, size_t hostBudget)
    : mPaged(std::make_unique<Paged>()) {
  const mesh::MeshStoreInfo& info = store->info();
  mPaged->resident = residentBytes(info);
  if (mPaged->resident > hostBudget)
    throw RenderLimitError("tet mesh '" + store->path().filename().string() + "': even paged, its " +
                           std::to_string(info.vertexCount) + " points take " + mebibytes(mPaged->resident) +
                           " in memory, above the host budget it may use, " + mebibytes(hostBudget) +
                           " (render's --host-cache; a server's host_cache_mb, shared among its open datasets)");
  mConstants.bounds = {glm::dvec3(info.boundsMin), glm::dvec3(info.boundsMax)};
  mConstants.scalarMin = info.scalarMin;
  mConstants.scalarMax = info.scalarMax;
  std::tie(mConstants.meanEdgeLength, mConstants.longestEdge) = store->edgeLengths();
  checkEdgeLengths(mConstants);
  mConstants.tetCount = info.tetCount;
  mConstants.pointCount = info.vertexCount;
  mConstants.field = info.field;
  mPaged->store = std::move(store);
  mPaged->budget = hostBudget;
  mPaged->counters.budgetBytes = hostBudget;
}

TetMeshSource::~TetMeshSource() = default;

size_t TetMeshSource::residentBytes(const mesh::MeshStoreInfo& info) {
  return size_t(info.vertexCount * (sizeof(glm::vec3) + sizeof(float)) +
                uint64_t(info.chunkCount) * (sizeof(mesh::ChunkInfo) + sizeof(mesh::MeshChunkRecord) + 8));
}

size_t TetMeshSource::chunkCount() const { return mPaged ? mPaged->store->chunkCount() : 1; }

std::vector<WeightedBox> TetMeshSource::partWeights() const {
  if (mPaged) {
    std::vector<mesh::ChunkInfo> chunks;
    for (size_t c = 0; c < mPaged->store->chunkCount(); ++c) chunks.push_back(mPaged->store->chunk(c));
    return chunkWeights(chunks);
  }
  return mChunks.empty() ? cellWeights(mWhole->mesh) : chunkWeights(mChunks);
}

std::shared_ptr<const TetMeshData> TetMeshSource::wholePart(const MeshPartBox& box) const {
  std::lock_guard lock(mPartsMutex);
  for (auto& [b, data] : mParts)
    if (b == box) return data;
  // A rank draws one part; a few are kept for tests and for a process drawing several in turn.
  constexpr size_t kKeptParts = 4;
  if (mParts.size() >= kKeptParts) mParts.erase(mParts.begin());
  mParts.emplace_back(box, cellsMeeting(*mWhole, box));
  return mParts.back().second;
}

std::shared_ptr<const TetMeshData> TetMeshSource::frameData(const Scene& scene, const TetView& view, FrameStats* stats,
                                                            const MeshPartBox* part) const {
  if (!mPaged) return part ? wholePart(*part) : mWhole;
  const auto start = Clock::now();
  const mesh::MeshStore& s = *mPaged->store;
  const Frustum frustum = Frustum::fromMatrix(view.clipFromWorld);
  const double inverse = 1.0 / (view.windowHi - view.windowLo);
  // The chunks in view, and of those the ones the transfer function does not make transparent. A frame reads every
  // chunk in view when they fit: the ray caster walks through transparent tets faster than it takes a pass to find
  // where each ray enters again beyond them (a pass per re-entry). Only when they do not fit are the transparent
  // ones left out, which changes nothing in the image (they add nothing to any ray).
  std::vector<uint32_t> visible, needed;
  int64_t culled = 0;
  for (size_t c = 0; c < s.chunkCount(); ++c) {
    const mesh::ChunkInfo& info = s.chunk(c);
    if (!frustum.intersects(Box{glm::dvec3(info.boundsMin), glm::dvec3(info.boundsMax)}) ||
        (part && !meets(*part, glm::dvec3(info.boundsMin), glm::dvec3(info.boundsMax)))) {
      ++culled;
      continue;
    }
    visible.push_back(uint32_t(c));
    if (!scene.skipEmpty || scene.transferFunction.contributes((double(info.scalarMin) - view.windowLo) * inverse,
                                                               (double(info.scalarMax) - view.windowLo) * inverse))
      needed.push_back(uint32_t(c));
  }
  std::shared_ptr<const TetMeshData> data;
  int64_t read = 0, skipped = 0;
  if (!needed.empty()) {  // else nothing in view shows: the background
    Paged& p = *mPaged;
    std::lock_guard lock(p.mutex);
    // A kept set, or a new one; nothing when `chunks` does not fit and may be given up (the view's transparent
    // chunks: the frame then does without them).
    auto obtain = [&](const std::vector<uint32_t>& chunks, bool mayGiveUp) -> std::shared_ptr<const TetMeshData> {
      if (auto it =
              std::find_if(p.kept.begin(), p.kept.end(), [&](const Paged::Kept& k) { return k.chunks == chunks; });
          it != p.kept.end()) {
        ++p.counters.hits;
        it->lastUse = ++p.uses;
        return it->data;
      }
      if (mayGiveUp && std::find(p.tooLarge.begin(), p.tooLarge.end(), chunks) != p.tooLarge.end()) return nullptr;
      std::shared_ptr<const TetMeshData> built;
      try {
        built = p.build(chunks, mConstants);
      } catch (const RenderLimitError&) {
        if (!mayGiveUp) throw;
        // Remembered (a few), so that the next frames of this view do not read it again to find the same.
        p.tooLarge.push_back(chunks);
        if (p.tooLarge.size() > Paged::kTooLargeKept) p.tooLarge.erase(p.tooLarge.begin());
        return nullptr;
      }
      read = int64_t(chunks.size());
      p.makeRoom(0);  // a smaller budget since the last frame drops what no frame holds
      return built;
    };
    data = obtain(visible, visible != needed);
    if (!data) {
      data = obtain(needed, false);
      skipped = int64_t(visible.size() - needed.size());
    }
  } else {
    skipped = int64_t(visible.size());
  }
  if (stats) {
    stats->tetChunksCulled = culled;
    stats->tetChunksSkippedEmpty = skipped;
    stats->tetChunksRead = read;
    stats->msPaging = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  }
  return data;
}

store::CacheStats TetMeshSource::cacheStats() const {
  if (!mPaged) return {};
  std::lock_guard lock(mPaged->mutex);
  store::CacheStats c = mPaged->counters;
  c.residentBricks = mPaged->kept.size();
  c.residentBytes = mPaged->resident + mPaged->live->bytes;
  c.budgetBytes = mPaged->budget;
  return c;
}

void TetMeshSource::setBudget(size_t bytes) const {
  if (!mPaged) return;
  std::lock_guard lock(mPaged->mutex);
  mPaged->budget = bytes;
  mPaged->tooLarge.clear();
  mPaged->makeRoom(0);
}

}  // namespace voxbrick::render
