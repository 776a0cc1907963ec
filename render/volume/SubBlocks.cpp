// Sub-block value ranges inside a brick and the front-to-back boxes a brick is drawn as.
#include "render/volume/SubBlocks.h"

#include <algorithm>
#include <bit>
#include <string>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {
namespace {

int64_t divUp(int64_t a, int64_t b) { return (a + b - 1) / b; }

}  // namespace

SubBlockRanges::SubBlockRanges(const void* samples, store::ValueType type, int brickSize, int subBlock,
                               const store::Vec3i& owned)
    : mBrickSize(brickSize), mSubBlock(subBlock), mOwned(owned) {
  if (!std::has_single_bit(unsigned(brickSize)) || !std::has_single_bit(unsigned(subBlock)) || subBlock >= brickSize)
    throw RenderInputError("sub-block " + std::to_string(subBlock) + " must be a power of two below the brick size " +
                           std::to_string(brickSize));
  for (int a = 0; a < 3; ++a)
    if (owned[a] < 1 || owned[a] > brickSize) throw RenderInputError("SubBlockRanges: owned voxels out of range");
  mLevels = std::countr_zero(unsigned(brickSize / subBlock));
  size_t total = 0;
  for (int l = 0; l <= mLevels; ++l) {
    mLevelOffset.push_back(total);
    total += size_t(1) << (3 * l);
  }
  mRanges.resize(total);

  // Finest level from the samples; each sub-block reads samples a - 1 .. a + S, i.e. data indices a .. a + S + 1.
  const int64_t side = brickSize + 2;
  const int64_t perAxis = int64_t{1} << mLevels;
  store::dispatchType(type, [&]<typename T>(T) {
    const T* data = static_cast<const T*>(samples);
    for (int64_t k = 0; k < perAxis; ++k)
      for (int64_t j = 0; j < perAxis; ++j)
        for (int64_t i = 0; i < perAxis; ++i) {
          const int64_t cell[3] = {i, j, k};
          int64_t lo[3], hi[3];
          bool present = true;
          for (int a = 0; a < 3; ++a) {
            lo[a] = cell[a] * subBlock;
            present = present && lo[a] < owned[a];
            hi[a] = std::min<int64_t>((cell[a] + 1) * subBlock, owned[a]) + 1;  // inclusive data index
          }
          if (!present) continue;
          float mn = float(data[(lo[2] * side + lo[1]) * side + lo[0]]), mx = mn;
          for (int64_t z = lo[2]; z <= hi[2]; ++z)
            for (int64_t y = lo[1]; y <= hi[1]; ++y) {
              const T* row = data + (z * side + y) * side;
              for (int64_t x = lo[0]; x <= hi[0]; ++x) {
                mn = std::min(mn, float(row[x]));
                mx = std::max(mx, float(row[x]));
              }
            }
          mRanges[index(mLevels, int(i), int(j), int(k))] = {mn, mx};
        }
  });
  // Coarser levels as unions of their existing children.
  for (int l = mLevels - 1; l >= 0; --l) {
    const int n = 1 << l;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          if (!exists(l, i, j, k)) continue;
          Range r{0, 0};
          bool first = true;
          for (int c = 0; c < 8; ++c) {
            const int ci = 2 * i + (c & 1), cj = 2 * j + ((c >> 1) & 1), ck = 2 * k + ((c >> 2) & 1);
            if (!exists(l + 1, ci, cj, ck)) continue;
            const Range cr = range(l + 1, ci, cj, ck);
            r = first ? cr : Range{std::min(r.min, cr.min), std::max(r.max, cr.max)};
            first = false;
          }
          mRanges[index(l, i, j, k)] = r;
        }
  }
}

size_t SubBlockRanges::index(int level, int i, int j, int k) const {
  const size_t n = size_t(1) << level;
  return mLevelOffset[size_t(level)] + (size_t(k) * n + size_t(j)) * n + size_t(i);
}

bool SubBlockRanges::exists(int level, int i, int j, int k) const {
  const int64_t e = edge(level);
  return i * e < mOwned.x && j * e < mOwned.y && k * e < mOwned.z;
}

SubBlockRanges::Range SubBlockRanges::range(int level, int i, int j, int k) const {
  return mRanges[index(level, i, j, k)];
}

namespace {

struct Walk {
  const SubBlockRanges& ranges;
  const store::Vec3i& brickLo;
  int level0Shift;  // the brick's pyramid level: its voxel v is level-0 voxel v << level0Shift
  const store::Vec3i& dims;
  const store::Vec3d& spacing;
  const Camera& camera;
  glm::dvec3 direction;
  const RangePredicate& contributes;
  std::vector<VoxelSpan>& out;
  SubBlockWalkStats& stats;

  VoxelSpan span(int level, int i, int j, int k) const {
    const int64_t e = ranges.edge(level);
    const int64_t cell[3] = {i, j, k};
    VoxelSpan s;
    for (int a = 0; a < 3; ++a) {
      s.lo[a] = toLevel0(brickLo[a] + cell[a] * e, a);
      s.hi[a] = toLevel0(brickLo[a] + std::min<int64_t>((cell[a] + 1) * e, ranges.owned()[a]), a);
    }
    return s;
  }

  /// The level-0 face of the brick's level face v along axis a.
  int64_t toLevel0(int64_t v, int a) const { return std::min<int64_t>(v << level0Shift, dims[a]); }

  int64_t finestBlocks(int level, int i, int j, int k) const {
    const int64_t s = ranges.subBlock(), e = ranges.edge(level);
    const int64_t cell[3] = {i, j, k};
    int64_t count = 1;
    for (int a = 0; a < 3; ++a)
      count *= divUp(std::min<int64_t>((cell[a] + 1) * e, ranges.owned()[a]) - cell[a] * e, s);
    return count;
  }

  /// Returns whether the node was emitted as one box (all its finest blocks contribute).
  bool visit(int level, int i, int j, int k) {
    const SubBlockRanges::Range r = ranges.range(level, i, j, k);
    if (!contributes(r.min, r.max)) {
      stats.subBlocksSkipped += finestBlocks(level, i, j, k);
      return false;
    }
    if (level == ranges.levels()) {
      out.push_back(span(level, i, j, k));
      return true;
    }
    const int64_t childEdge = ranges.edge(level + 1);
    const int cell[3] = {i, j, k};
    int highNear = 0;
    for (int a = 0; a < 3; ++a) {
      bool highFirst;
      if (camera.orthographic) {
        highFirst = direction[a] < 0;
      } else {
        const double split = voxelFace(toLevel0(brickLo[a] + (2 * cell[a] + 1) * childEdge, a), dims[a], spacing[a]);
        highFirst = camera.eye[a] >= split;
      }
      if (highFirst) highNear |= 1 << a;
    }
    const size_t first = out.size();
    bool full = true;
    for (int q = 0; q < 8; ++q) {
      const int c = q ^ highNear;
      const int ci = 2 * i + (c & 1), cj = 2 * j + ((c >> 1) & 1), ck = 2 * k + ((c >> 2) & 1);
      if (ranges.exists(level + 1, ci, cj, ck)) full = visit(level + 1, ci, cj, ck) && full;
    }
    if (full) {
      out.resize(first);
      out.push_back(span(level, i, j, k));
    }
    return full;
  }
};

}  // namespace

void subBlockBoxes(const SubBlockRanges& ranges, const store::Vec3i& brickLo, int level, const store::Vec3i& dims,
                   const store::Vec3d& spacing, const Camera& camera, const RangePredicate& contributes,
                   std::vector<VoxelSpan>& out, SubBlockWalkStats& stats) {
  const size_t before = out.size();
  Walk walk{ranges, brickLo, level, dims, spacing, camera, camera.viewDirection(), contributes, out, stats};
  walk.visit(0, 0, 0, 0);
  stats.boxes += int64_t(out.size() - before);
}

}  // namespace voxbrick::render
