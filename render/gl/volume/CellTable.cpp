// Marking the cells of a batch, computing how far a ray may leap from each empty cell, and uploading the table.
#include "render/gl/volume/CellTable.h"

#include <algorithm>
#include <bit>
#include <limits>

#include "render/core/RenderErrors.h"
#include "render/gl/Bindings.h"
#include "render/gl/volume/SlicingPass.h"
#include "render/volume/Traversal.h"

namespace voxbrick::render {
namespace {

const glm::i16vec4 kEmpty(0, 0, 0, CellTable::kNothing);
const glm::i16vec4 kDeferred(0, 0, 0, CellTable::kOtherBatch);

int cellsAlong(int voxels, int cellSize) { return (voxels + cellSize - 1) / cellSize; }

}  // namespace

void CellTable::makeTexture(const glm::ivec3& cells, int cellSize) {
  mShift = std::countr_zero(unsigned(cellSize));
  if (cells == mCells && mTexture) return;
  mCells = cells;
  mTexture = Texture(mGl, GL_TEXTURE_3D);
  mTexture.bind(VB_UNIT_CELLS);
  mGl.glTexStorage3D(GL_TEXTURE_3D, 1, GL_RGBA16I, cells.x, cells.y, cells.z);
  mGl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  mGl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  mKept = false;
}

void CellTable::begin(const glm::ivec3& dims, int cellSize) {
  const glm::ivec3 cells(cellsAlong(dims.x, cellSize), cellsAlong(dims.y, cellSize), cellsAlong(dims.z, cellSize));
  makeTexture(cells, cellSize);
  mKept = false;
  mDeferred.clear();
  mHost.assign(size_t(cells.x) * size_t(cells.y) * size_t(cells.z), kEmpty);
  mMarked = false;
}

bool CellTable::resume(const glm::ivec3& dims, int cellSize) {
  const glm::ivec3 cells(cellsAlong(dims.x, cellSize), cellsAlong(dims.y, cellSize), cellsAlong(dims.z, cellSize));
  const bool sameGrid = cells == mCells && std::countr_zero(unsigned(cellSize)) == mShift;
  makeTexture(cells, cellSize);
  mMarked = false;
  if (mKept && sameGrid) return true;
  mDeferred.clear();
  mHost.assign(size_t(cells.x) * size_t(cells.y) * size_t(cells.z), kEmpty);
  mBlocks = (cells + (kLeapBlock - 1)) / kLeapBlock;
  mChanged.assign(size_t(mBlocks.x) * size_t(mBlocks.y) * size_t(mBlocks.z), 0);
  mChangedLo = mBlocks, mChangedHi = glm::ivec3(0);
  touch(glm::ivec3(0), cells);  // every cell is sent: the texture holds another table
  mKept = true;
  return false;
}

void CellTable::deferAll(const TraversalResult& visible, int brickSize) {
  mDeferred.assign(mHost.size(), 0);
  const glm::ivec3 dims = mCells << mShift;
  for (const BrickDraw& d : visible.bricks) {
    const int m = int(d.key.level);
    const glm::ivec3 lo = glm::ivec3(int(d.key.i), int(d.key.j), int(d.key.k)) * (brickSize << m);
    const glm::ivec3 hi = glm::min(lo + (brickSize << m), dims);
    const glm::ivec3 c0 = lo >> mShift, c1 = (hi + ((1 << mShift) - 1)) >> mShift;
    for (int z = c0.z; z < c1.z; ++z)
      for (int y = c0.y; y < c1.y; ++y) std::fill_n(mDeferred.begin() + ptrdiff_t(index(c0.x, y, z)), c1.x - c0.x, 1);
  }
  reset();
}

void CellTable::deferOutside(const glm::ivec3& lo, const glm::ivec3& hi) {
  if (mDeferred.empty()) mDeferred.assign(mHost.size(), 0);
  const glm::ivec3 c0 = lo >> mShift, c1 = glm::min((hi + ((1 << mShift) - 1)) >> mShift, mCells);
  const glm::ivec3 r0 = glm::max(c0 - 1, glm::ivec3(0)), r1 = glm::min(c1 + 1, mCells);
  for (int z = r0.z; z < r1.z; ++z)
    for (int y = r0.y; y < r1.y; ++y)
      for (int x = r0.x; x < r1.x; ++x)
        if (x < c0.x || x >= c1.x || y < c0.y || y >= c1.y || z < c0.z || z >= c1.z) mDeferred[index(x, y, z)] = 1;
  reset();
}

void CellTable::add(const QueuedBox& box) {
  constexpr int lo16 = std::numeric_limits<int16_t>::min(), hi16 = std::numeric_limits<int16_t>::max();
  for (int a = 0; a < 3; ++a)
    if (box.payload[a] < lo16 || box.payload[a] > hi16)
      throw RenderError("ray casting: atlas offset " + std::to_string(box.payload[a]) + " does not fit the cell table");
  const glm::i16vec4 entry(box.payload);
  const glm::ivec3 lo = box.ownLo >> mShift;
  const glm::ivec3 hi = glm::min((box.ownHi + ((1 << mShift) - 1)) >> mShift, mCells);
  for (int z = lo.z; z < hi.z; ++z)
    for (int y = lo.y; y < hi.y; ++y) std::fill_n(mHost.begin() + ptrdiff_t(index(lo.x, y, z)), hi.x - lo.x, entry);
  const bool any = lo.x < hi.x && lo.y < hi.y && lo.z < hi.z;
  mMarked = mMarked || any;
  if (mKept && any) touch(lo, hi);
}

void CellTable::clear(const glm::ivec3& lo, const glm::ivec3& hi) {
  const glm::ivec3 c0 = glm::max(lo >> mShift, glm::ivec3(0));
  const glm::ivec3 c1 = glm::min((hi + ((1 << mShift) - 1)) >> mShift, mCells);
  if (c0.x >= c1.x || c0.y >= c1.y || c0.z >= c1.z) return;
  for (int z = c0.z; z < c1.z; ++z)
    for (int y = c0.y; y < c1.y; ++y) std::fill_n(mHost.begin() + ptrdiff_t(index(c0.x, y, z)), c1.x - c0.x, kEmpty);
  touch(c0, c1);
}

void CellTable::touch(const glm::ivec3& c0, const glm::ivec3& c1) {
  const glm::ivec3 b0 = c0 / kLeapBlock, b1 = (c1 + (kLeapBlock - 1)) / kLeapBlock;
  for (int z = b0.z; z < b1.z; ++z)
    for (int y = b0.y; y < b1.y; ++y)
      std::fill_n(mChanged.begin() + ptrdiff_t((size_t(z) * size_t(mBlocks.y) + size_t(y)) * size_t(mBlocks.x) + size_t(b0.x)),
                  b1.x - b0.x, 1);
  mChangedLo = glm::min(mChangedLo, b0), mChangedHi = glm::max(mChangedHi, b1);
}

void CellTable::send(const glm::ivec3& lo, const glm::ivec3& hi) {
  mTexture.bind(VB_UNIT_CELLS);
  mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
  mGl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  const bool whole = lo == glm::ivec3(0) && hi == mCells;
  if (!whole) {
    mGl.glPixelStorei(GL_UNPACK_ROW_LENGTH, mCells.x);
    mGl.glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, mCells.y);
  }
  const glm::ivec3 size = hi - lo;
  mGl.glTexSubImage3D(GL_TEXTURE_3D, 0, lo.x, lo.y, lo.z, size.x, size.y, size.z, GL_RGBA_INTEGER, GL_SHORT,
                      mHost.data() + index(lo.x, lo.y, lo.z));
  if (!whole) {
    mGl.glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    mGl.glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, 0);
  }
}

void CellTable::upload() {
  computeLeaps(mHost, mCells);
  send(glm::ivec3(0), mCells);
  reset();
}

int64_t CellTable::uploadChanges() {
  mTexture.bind(VB_UNIT_CELLS);
  if (mChangedLo.x >= mChangedHi.x || mChangedLo.y >= mChangedHi.y || mChangedLo.z >= mChangedHi.z) return 0;
  for (int z = mChangedLo.z; z < mChangedHi.z; ++z)
    for (int y = mChangedLo.y; y < mChangedHi.y; ++y)
      for (int x = mChangedLo.x; x < mChangedHi.x; ++x) {
        if (mChanged[(size_t(z) * size_t(mBlocks.y) + size_t(y)) * size_t(mBlocks.x) + size_t(x)])
          computeBlockLeaps(mHost, mCells, {x, y, z});
      }
  // Each row of blocks (along x) sends the run from its first changed block to its last: a change here and there
  // sends its own rows, not the box around them all.
  int64_t sent = 0;
  for (int z = mChangedLo.z; z < mChangedHi.z; ++z)
    for (int y = mChangedLo.y; y < mChangedHi.y; ++y) {
      const uint8_t* row = &mChanged[(size_t(z) * size_t(mBlocks.y) + size_t(y)) * size_t(mBlocks.x)];
      int first = mChangedLo.x, last = mChangedHi.x - 1;
      while (first <= last && !row[first]) ++first;
      while (last >= first && !row[last]) --last;
      if (first > last) continue;
      const glm::ivec3 lo = glm::ivec3(first, y, z) * kLeapBlock;
      const glm::ivec3 hi = glm::min(glm::ivec3(last + 1, y + 1, z + 1) * kLeapBlock, mCells);
      send(lo, hi);
      sent += int64_t(hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z);
    }
  std::fill(mChanged.begin(), mChanged.end(), 0);
  mChangedLo = mBlocks, mChangedHi = glm::ivec3(0);
  return sent;
}

void CellTable::reset() {
  if (mDeferred.empty())
    std::fill(mHost.begin(), mHost.end(), kEmpty);
  else
    for (size_t i = 0; i < mHost.size(); ++i) mHost[i] = mDeferred[i] ? kDeferred : kEmpty;
  mMarked = false;
}

void computeBlockLeaps(std::vector<glm::i16vec4>& cells, const glm::ivec3& grid, const glm::ivec3& block) {
  // Which aligned sub-blocks of 2^j cells have nothing to draw, level by level inside the block (cells past the grid
  // count as nothing): empty[j] holds (8 >> j)^3 flags, x fastest.
  constexpr int N = CellTable::kLeapBlock;
  bool empty[CellTable::kMaxLeapLevel + 1][N * N * N];
  const glm::ivec3 base = block * N;
  const auto cellIndex = [&](int x, int y, int z) {
    return (size_t(z) * size_t(grid.y) + size_t(y)) * size_t(grid.x) + size_t(x);
  };
  for (int z = 0; z < N; ++z)
    for (int y = 0; y < N; ++y)
      for (int x = 0; x < N; ++x) {
        const glm::ivec3 c = base + glm::ivec3(x, y, z);
        empty[0][(z * N + y) * N + x] = c.x >= grid.x || c.y >= grid.y || c.z >= grid.z ||
                                        cells[cellIndex(c.x, c.y, c.z)].w == CellTable::kNothing;
      }
  for (int j = 1; j <= CellTable::kMaxLeapLevel; ++j) {
    const int n = N >> j, finer = n * 2;
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          bool e = true;
          for (int c = 0; c < 8 && e; ++c)
            e = empty[j - 1][((2 * z + (c >> 2)) * finer + 2 * y + ((c >> 1) & 1)) * finer + 2 * x + (c & 1)];
          empty[j][(z * n + y) * n + x] = e;
        }
  }
  const glm::ivec3 end = glm::min(base + N, grid);
  for (int z = base.z; z < end.z; ++z)
    for (int y = base.y; y < end.y; ++y)
      for (int x = base.x; x < end.x; ++x) {
        glm::i16vec4& cell = cells[cellIndex(x, y, z)];
        if (cell.w != CellTable::kNothing) continue;
        // The largest empty block around it: the blocks nest, so the coarsest empty level is the one.
        int leap = 0;
        const glm::ivec3 local(x - base.x, y - base.y, z - base.z);
        for (int j = CellTable::kMaxLeapLevel; j > 0 && leap == 0; --j) {
          const int n = N >> j;
          const glm::ivec3 b = local >> j;
          if (empty[j][(b.z * n + b.y) * n + b.x]) leap = j;
        }
        cell.x = int16_t(leap);
      }
}

void computeLeaps(std::vector<glm::i16vec4>& cells, const glm::ivec3& grid) {
  const glm::ivec3 blocks = (grid + (CellTable::kLeapBlock - 1)) / CellTable::kLeapBlock;
  for (int z = 0; z < blocks.z; ++z)
    for (int y = 0; y < blocks.y; ++y)
      for (int x = 0; x < blocks.x; ++x) computeBlockLeaps(cells, grid, {x, y, z});
}

}  // namespace voxbrick::render
