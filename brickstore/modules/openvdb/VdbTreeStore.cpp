// A .vdb read live (the OpenVDB module's VdbStore): the pass over the tree at open, level-0 bricks from leaves,
// coarse bricks from finer bricks.
#include "brickstore/modules/openvdb/OpenVdbModule.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include <openvdb/openvdb.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "brickstore/format/BrickMath.h"
#include "brickstore/format/Errors.h"
#include "brickstore/format/HistogramBuilder.h"
#include "brickstore/read/LiveBricks.h"
#include "brickstore/read/VdbStore.h"
#include "brickstore/vdb/VdbGrid.h"

namespace voxbrick::store {
namespace {

using live::averageFromFiner;
using live::gatherSamples;
using live::OwnedStats;

using Clock = std::chrono::steady_clock;
using Tree = openvdb::FloatTree;
using Leaf = Tree::LeafNodeType;
// One accessor per call and thread: unregistered, so making one costs no lock on the tree.
using Accessor = openvdb::tree::ValueAccessor<const Tree, false>;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

/// A voxel value as prep ingests it: NaN and Inf become the background (prep's default non-finite policy).
float sanitize(float v, float background) { return std::isfinite(v) ? v : background; }

/// The level-0 bricks whose voxels (border included) meet the voxels [lo, hi]: brick i reads [i*B - 1, i*B + B].
void bricksReading(const Vec3i& lo, const Vec3i& hi, int64_t B, const Vec3i& bricks, Vec3i& first, Vec3i& last) {
  for (int a = 0; a < 3; ++a) {
    first[a] = std::max<int64_t>(0, (lo[a] + B - 1) / B - 1);
    last[a] = std::min<int64_t>(bricks[a] - 1, (hi[a] + 1) / B);
  }
}

/// Level-0 voxels [lo, hi] (volume coordinates; voxel 0 is grid coordinate `origin`) into `block`, x fastest: one
/// leaf lookup per 8^3 block of the tree; where there is no leaf, the tile's value (or the background).
void fillFromTree(const Tree& tree, const openvdb::Coord& origin, const Vec3i& lo, const Vec3i& hi, float* block) {
  Accessor acc(tree);
  const float background = tree.background();
  const int64_t sx = hi.x - lo.x + 1, sy = hi.y - lo.y + 1;
  const int gx0 = origin.x() + int(lo.x), gy0 = origin.y() + int(lo.y), gz0 = origin.z() + int(lo.z);
  const int gx1 = origin.x() + int(hi.x), gy1 = origin.y() + int(hi.y), gz1 = origin.z() + int(hi.z);
  auto at = [&](int x, int y, int z) { return block + (x - gx0) + sx * ((y - gy0) + sy * int64_t(z - gz0)); };
  for (int bz = gz0 & ~7; bz <= gz1; bz += 8)
    for (int by = gy0 & ~7; by <= gy1; by += 8)
      for (int bx = gx0 & ~7; bx <= gx1; bx += 8) {
        const openvdb::Coord nodeOrigin(bx, by, bz);
        const int x0 = std::max(bx, gx0), x1 = std::min(bx + 7, gx1);
        const int y0 = std::max(by, gy0), y1 = std::min(by + 7, gy1);
        const int z0 = std::max(bz, gz0), z1 = std::min(bz + 7, gz1);
        if (const Leaf* leaf = acc.probeConstLeaf(nodeOrigin)) {
          const float* values = leaf->buffer().data();  // offset ((x & 7) << 6) | ((y & 7) << 3) | (z & 7)
          for (int z = z0; z <= z1; ++z)
            for (int y = y0; y <= y1; ++y) {
              float* out = at(x0, y, z);
              const float* in = values + (((y & 7) << 3) | (z & 7));
              for (int x = x0; x <= x1; ++x) *out++ = sanitize(in[(x & 7) << 6], background);
            }
        } else {
          const float v = sanitize(acc.getValue(nodeOrigin), background);
          for (int z = z0; z <= z1; ++z)
            for (int y = y0; y <= y1; ++y) std::fill_n(at(x0, y, z), x1 - x0 + 1, v);
        }
      }
}

/// A tile of the tree inside the volume whose value is not the background.
struct Tile {
  Vec3i lo, hi;  // volume coordinates, inclusive
  float value;
  int64_t voxels() const { return (hi.x - lo.x + 1) * (hi.y - lo.y + 1) * (hi.z - lo.z + 1); }
};

/// What of the tree can hold anything but the background inside the volume: its leaf nodes, and its tiles (of any
/// level above the leaves) whose value is neither the background nor NaN/Inf (read as the background; their voxels
/// are counted). Every other voxel of the volume is the background.
struct Topology {
  Topology(const Tree& tree, const openvdb::Coord& volumeOrigin, const Vec3i& dims)
      : origin(volumeOrigin),
        volume(origin, origin + openvdb::Coord(int(dims.x) - 1, int(dims.y) - 1, int(dims.z) - 1)) {
    for (auto it = tree.cbeginLeaf(); it; ++it) leaves.push_back(&*it);
    Tree::ValueAllCIter it = tree.cbeginValueAll();
    it.setMaxDepth(Tree::ValueAllCIter::LEAF_DEPTH - 1);
    for (; it; ++it) {
      openvdb::CoordBBox box;
      it.getBoundingBox(box);
      Tile tile{};
      if (!clip(box, tile.lo, tile.hi)) continue;
      if (!std::isfinite(*it))
        nonFiniteTileVoxels += tile.voxels();
      else if (*it != tree.background())
        tiles.push_back({tile.lo, tile.hi, *it});
    }
  }

  /// `box` (grid coordinates) clipped to the volume, in volume coordinates; false if nothing is left.
  bool clip(openvdb::CoordBBox box, Vec3i& lo, Vec3i& hi) const {
    box.intersect(volume);
    if (box.empty()) return false;
    for (int a = 0; a < 3; ++a) {
      lo[a] = box.min()[a] - origin[a];
      hi[a] = box.max()[a] - origin[a];
    }
    return true;
  }

  openvdb::Coord origin;      // grid coordinate of volume voxel (0, 0, 0)
  openvdb::CoordBBox volume;  // the volume in grid coordinates
  std::vector<const Leaf*> leaves;
  std::vector<Tile> tiles;
  int64_t nonFiniteTileVoxels = 0;
};

/// The level-0 histogram over [lo, hi] (prep's bins) and the number of NaN/Inf voxels, voxel by voxel: leaves in
/// parallel, then tiles, then the background for every voxel neither covers.
Histogram voxelHistogram(const Topology& topology, const Vec3i& dims, float background, double lo, double hi,
                         int64_t& nonFinite) {
  struct Counts {
    explicit Counts(const HistogramBuilder& empty) : histogram(empty) {}
    HistogramBuilder histogram;
    int64_t covered = 0, nonFinite = 0;
  };
  const HistogramBuilder empty(ValueType::F32, lo, hi);
  tbb::enumerable_thread_specific<Counts> perThread([&] { return Counts(empty); });
  const std::vector<const Leaf*>& leaves = topology.leaves;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves.size()), [&](const tbb::blocked_range<size_t>& r) {
    Counts& counts = perThread.local();
    std::array<float, Leaf::SIZE> values;
    for (size_t l = r.begin(); l != r.end(); ++l) {
      Vec3i vlo, vhi;
      if (!topology.clip(leaves[l]->getNodeBoundingBox(), vlo, vhi)) continue;
      const openvdb::Coord leafOrigin = leaves[l]->origin();
      const float* data = leaves[l]->buffer().data();
      size_t count = 0;
      for (int64_t z = vlo.z; z <= vhi.z; ++z)
        for (int64_t y = vlo.y; y <= vhi.y; ++y)
          for (int64_t x = vlo.x; x <= vhi.x; ++x) {
            const openvdb::Coord g = topology.origin + openvdb::Coord(int(x), int(y), int(z)) - leafOrigin;
            const float v = data[(g.x() << 6) | (g.y() << 3) | g.z()];
            counts.nonFinite += !std::isfinite(v);
            values[count++] = sanitize(v, background);
          }
      counts.histogram.add(values.data(), int64_t(count));
      counts.covered += int64_t(count);
    }
  });
  HistogramBuilder histogram(ValueType::F32, lo, hi);
  int64_t covered = 0;
  nonFinite = topology.nonFiniteTileVoxels;
  for (const Counts& counts : perThread) {
    histogram.merge(counts.histogram);
    covered += counts.covered;
    nonFinite += counts.nonFinite;
  }
  for (const Tile& tile : topology.tiles) {
    histogram.addRepeated(tile.value, uint64_t(tile.voxels()));
    covered += tile.voxels();
  }
  histogram.addRepeated(background, uint64_t(dims.volume() - covered));
  return histogram.finish();
}

/// The level-0 bricks (flags by brick index) that read a voxel of a leaf or of a tile the topology lists; every
/// other brick reads only the background.
std::vector<uint8_t> bricksNearData(const Topology& topology, int64_t B, const Vec3i& nb) {
  std::vector<uint8_t> near(size_t(nb.volume()), 0);
  auto mark = [&](const Vec3i& lo, const Vec3i& hi) {
    Vec3i first, last;
    bricksReading(lo, hi, B, nb, first, last);
    for (int64_t k = first.z; k <= last.z; ++k)
      for (int64_t j = first.y; j <= last.y; ++j)
        for (int64_t i = first.x; i <= last.x; ++i) near[size_t(i + nb.x * (j + nb.y * k))] = 1;
  };
  for (const Leaf* leaf : topology.leaves) {
    Vec3i lo, hi;
    if (topology.clip(leaf->getNodeBoundingBox(), lo, hi)) mark(lo, hi);
  }
  for (const Tile& tile : topology.tiles) mark(tile.lo, tile.hi);
  return near;
}

/// Extracts level-0 brick `idx` of a volume of `n` voxels once: its record (exact range and emptiness, border
/// included; a brick that is not empty is stored at `storedSize` bytes) into `rec`, and the statistics of the voxels
/// it owns. `block` and `samples` (of (B + 2)^3 values) are scratch.
OwnedStats scanBrick(const Tree& tree, const openvdb::Coord& origin, const Vec3i& idx, int64_t B, const Vec3i& n,
                     uint32_t storedSize, BrickRecord& rec, std::vector<float>& block, std::vector<float>& samples) {
  const float background = tree.background();
  Vec3i lo, hi;
  brickVoxels(idx, B, n, lo, hi);
  block.resize(size_t((hi.x - lo.x + 1) * (hi.y - lo.y + 1) * (hi.z - lo.z + 1)));
  fillFromTree(tree, origin, lo, hi, block.data());
  gatherSamples(block.data(), lo, hi, idx, B, n, samples.data());
  bool empty = true;
  const MinMaxPair range = sampleRange(samples.data(), samples.size(), background, empty);
  rec.min = range.min;
  rec.max = range.max;
  rec.compressedSize = empty ? 0 : storedSize;
  return live::ownedStats(samples.data(), idx, B, n, double(background));
}

/// VdbStore over the grid held in memory (brickstore/read/VdbStore.h says what it reads).
class VdbTreeStore final : public VdbStore, public std::enable_shared_from_this<VdbTreeStore> {
 public:
  static std::shared_ptr<const VdbStore> open(const std::filesystem::path& file, const StoreOpenOptions& options);

  int64_t bricksBuilt(int level) const override;

 protected:
  void readStored(const BrickKey& key, void* dst, const BrickSamplesFetch& finer) const override;

 private:
  VdbTreeStore() = default;
  void scan();

  openvdb::FloatGrid::Ptr mGrid;
  openvdb::Coord mOrigin;                          // grid coordinate of volume voxel (0, 0, 0)
  std::unique_ptr<std::atomic<int64_t>[]> mBuilt;  // per level
};

std::shared_ptr<const VdbStore> VdbTreeStore::open(const std::filesystem::path& file, const StoreOpenOptions& options) {
  checkBrickSize(options.brickSize);
  const auto start = Clock::now();
  VdbFloatGrid chosen = readVdbFloatGrid(file.string(), options.gridName);
  // The records are sized from the bricks of the active voxels' bounding box, however sparse: refused before that.
  checkLiveBrickCount(chosen.dims, options.brickSize, file.string() + ": the active voxels' bounding box");

  std::shared_ptr<VdbTreeStore> store(new VdbTreeStore());
  store->mOpenStats.readSeconds = secondsSince(start);
  store->mPath = file;
  store->mGrid = chosen.grid;
  store->mOrigin = chosen.bbox.min();

  StoreMeta& meta = store->mMeta;
  meta.dims = chosen.dims;
  meta.spacing = chosen.spacing;
  meta.type = ValueType::F32;
  meta.background = chosen.grid->background();
  meta.brickSize = options.brickSize;
  meta.bytesRaw = meta.dims.volume() * int64_t(sizeof(float));
  meta.source = chosen.description;
  meta.vdbFiles = {file.filename().string()};
  std::error_code ec;
  meta.bytesVdb = int64_t(std::filesystem::file_size(file, ec));
  if (ec) throw IoError("cannot stat " + file.string() + ": " + ec.message());

  store->layOutLevels();
  store->mBuilt = std::make_unique<std::atomic<int64_t>[]>(meta.levels.size());
  for (size_t l = 0; l < meta.levels.size(); ++l) store->mBuilt[l] = 0;

  const auto scanStart = Clock::now();
  store->scan();
  store->buildOctree();
  for (int m = 1; m < store->levelCount(); ++m) store->deriveCoarseRecords(m);
  store->mOpenStats.scanSeconds = secondsSince(scanStart);
  return store;
}

void VdbTreeStore::scan() {
  const Tree& tree = mGrid->tree();
  const openvdb::Coord origin = mOrigin;
  const Vec3i n = mMeta.dims, nb = mMeta.levels[0].bricks;
  const int64_t B = mMeta.brickSize;
  const float background = tree.background();
  const uint32_t storedSize = uint32_t(brickBytes());
  const Topology topology(tree, origin, n);
  mOpenStats.leafNodes = int64_t(topology.leaves.size());
  mOpenStats.tiles = int64_t(topology.tiles.size());

  const std::vector<uint8_t> near = bricksNearData(topology, B, nb);
  std::vector<int64_t> candidates;
  for (int64_t b = 0; b < nb.volume(); ++b)
    if (near[size_t(b)]) candidates.push_back(b);
  mOpenStats.bricksScanned = int64_t(candidates.size());
  std::vector<OwnedStats> owned(candidates.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, candidates.size()), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<float> block, samples(size_t((B + 2) * (B + 2) * (B + 2)));
    for (size_t c = r.begin(); c != r.end(); ++c) {
      const int64_t b = candidates[c];
      const Vec3i idx{b % nb.x, (b / nb.x) % nb.y, b / (nb.x * nb.y)};
      owned[c] = scanBrick(tree, origin, idx, B, n, storedSize, mRecords[size_t(b)], block, samples);
    }
  });
  for (int64_t b = 0; b < nb.volume(); ++b)
    if (!near[size_t(b)]) mRecords[size_t(b)] = BrickRecord{0, 0, 0, background, background, 0};

  OwnedStats all;
  for (const OwnedStats& o : owned) all.merge(o);
  if (int64_t(candidates.size()) < nb.volume())
    all.min = std::min(all.min, double(background)), all.max = std::max(all.max, double(background));
  const double lo = all.min, hi = all.max;
  mMeta.valueMin = lo;
  mMeta.valueMax = hi;
  mMeta.activeVoxels = all.active;
  for (int64_t b = 0; b < nb.volume(); ++b) mMeta.levels[0].bricksStored += mRecords[size_t(b)].compressedSize != 0;

  mMeta.histogram = voxelHistogram(topology, n, background, lo, hi, mMeta.nonFiniteReplaced);
}

int64_t VdbTreeStore::bricksBuilt(int level) const {
  if (level < 0 || level >= levelCount()) throw InputError("VdbStore::bricksBuilt: no level " + std::to_string(level));
  return mBuilt[size_t(level)].load(std::memory_order_relaxed);
}

void VdbTreeStore::readStored(const BrickKey& key, void* dst, const BrickSamplesFetch& finer) const {
  const int64_t B = mMeta.brickSize;
  const int level = int(key.level);
  const Vec3i idx{key.i, key.j, key.k};
  const Vec3i n = mMeta.levels[size_t(level)].dims;
  Vec3i lo, hi;
  brickVoxels(idx, B, n, lo, hi);
  // Buffers per call, not per thread: building a coarse brick builds finer ones on the same thread, and a thread
  // keeping the largest buffer of every level would hold far more than a brick's worth for its lifetime.
  std::vector<float> block(size_t((hi.x - lo.x + 1) * (hi.y - lo.y + 1) * (hi.z - lo.z + 1)));

  if (level == 0) {
    fillFromTree(mGrid->tree(), mOrigin, lo, hi, block.data());
  } else {
    if (!finer)
      return live::readWithoutFetch(shared_from_this(), [&](const BrickSamplesFetch& f) { readStored(key, dst, f); });
    averageFromFiner<float>(*this, key.level - 1, lo, hi, mMeta.levels[size_t(level) - 1].dims, finer, block.data());
  }
  gatherSamples(block.data(), lo, hi, idx, B, n, static_cast<float*>(dst));
  mBuilt[size_t(level)].fetch_add(1, std::memory_order_relaxed);
}

}  // namespace

std::shared_ptr<const VdbStore> openVdbTreeStore(const std::filesystem::path& file, const StoreOpenOptions& options) {
  return VdbTreeStore::open(file, options);
}

}  // namespace voxbrick::store
