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
constexpr int N = CellTable::kLeapBlock;

int cellsAlong(int voxels, int cellSize) { return (voxels + cellSize - 1) / cellSize; }

/// An integer 3D texture of `size` texels in `format`, read texel by texel, bound to `unit`.
Texture integerTexture(const Gl& gl, int unit, GLenum format, const glm::ivec3& size) {
  Texture t(gl, GL_TEXTURE_3D);
  t.bind(unit);
  gl.glTexStorage3D(GL_TEXTURE_3D, 1, format, size.x, size.y, size.z);
  gl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  gl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return t;
}

}  // namespace

CellTable::CellTable(const Gl& gl) : mGl(gl) {}

void CellTable::setGrid(const glm::ivec3& dims, int cellSize, bool paged) {
  mShift = std::countr_zero(unsigned(cellSize));
  const glm::ivec3 cells(cellsAlong(dims.x, cellSize), cellsAlong(dims.y, cellSize), cellsAlong(dims.z, cellSize));
  const glm::ivec3 blocks = (cells + (N - 1)) / N;
  if (paged != mPaged) mKept = false;
  mPaged = paged;
  if (!paged && (cells != mDenseCells || !mDenseTexture)) {
    mDenseTexture = integerTexture(mGl, VB_UNIT_CELLS, GL_RGBA16I, cells);
    mDenseCells = cells;
    mKept = false;
  }
  if (paged && (blocks != mDirectoryBlocks || !mDirectoryTexture)) {
    mDirectoryTexture = integerTexture(mGl, VB_UNIT_CELL_DIRECTORY, GL_R32I, blocks);
    mDirectoryBlocks = blocks;
    mKept = false;
  }
  mCells = cells, mBlocks = blocks;
  mDirectory.assign(size_t(blocks.x) * size_t(blocks.y) * size_t(blocks.z), kBlockNothing);
  mPool.clear();
  mFreePages.clear();
  mPageCount = 0;
  mBaseDirectory.clear();
  mMarked = false;
}

void CellTable::begin(const glm::ivec3& dims, int cellSize, bool paged) {
  setGrid(dims, cellSize, paged);
  mKept = false;
}

bool CellTable::resume(const glm::ivec3& dims, int cellSize, bool paged) {
  const glm::ivec3 cells(cellsAlong(dims.x, cellSize), cellsAlong(dims.y, cellSize), cellsAlong(dims.z, cellSize));
  mMarked = false;
  if (mKept && cells == mCells && std::countr_zero(unsigned(cellSize)) == mShift && paged == mPaged) return true;
  setGrid(dims, cellSize, paged);
  mChanged.assign(mDirectory.size(), 0);
  mChangedLo = mBlocks, mChangedHi = glm::ivec3(0);
  touch(glm::ivec3(0), mBlocks);  // every block is sent: the GPU holds another table
  mKept = true;
  return false;
}

int32_t CellTable::newPage(const glm::i16vec4& entry) {
  int32_t page;
  if (!mFreePages.empty()) {
    page = mFreePages.back();
    mFreePages.pop_back();
  } else {
    if (int64_t(mPageCount + 1) * kPageCells > std::numeric_limits<int32_t>::max())
      throw RenderError("ray casting: the cell table needs more than " + std::to_string(mPageCount) + " pages");
    page = mPageCount++;
    mPool.resize(size_t(mPageCount) * kPageCells);
  }
  std::fill_n(mPool.begin() + ptrdiff_t(page) * kPageCells, kPageCells, entry);
  return page;
}

void CellTable::fill(const glm::ivec3& c0, const glm::ivec3& c1, const glm::i16vec4& entry) {
  if (c0.x >= c1.x || c0.y >= c1.y || c0.z >= c1.z) return;
  // Nothing to draw and another batch's are whole blocks without a page when a fill covers the block; a drawn entry
  // always has a page (a block holds several bricks' payloads).
  const int32_t uniform = entry == kEmpty ? kBlockNothing : entry == kDeferred ? kBlockOtherBatch : 0;
  const glm::ivec3 b0 = c0 / N, b1 = (c1 + (N - 1)) / N;
  for (int bz = b0.z; bz < b1.z; ++bz)
    for (int by = b0.y; by < b1.y; ++by)
      for (int bx = b0.x; bx < b1.x; ++bx) {
        const glm::ivec3 b(bx, by, bz);
        int32_t& page = mDirectory[blockIndex(b)];
        if (page < 0 && page == uniform) continue;
        // The part of [c0, c1) in this block, in its page's cells (cells past the grid count as covered).
        const glm::ivec3 lo = glm::max(c0, b * N) - b * N;
        const glm::ivec3 hi = glm::min(c1, b * N + N) - b * N;
        const glm::ivec3 end = glm::min(mCells - b * N, glm::ivec3(N));  // the block's cells inside the grid
        if (uniform < 0 && lo == glm::ivec3(0) && glm::all(glm::greaterThanEqual(hi, end))) {
          if (page >= 0) mFreePages.push_back(page);
          page = uniform;
          continue;
        }
        if (page < 0) page = newPage(page == kBlockOtherBatch ? kDeferred : kEmpty);
        glm::i16vec4* cells = mPool.data() + size_t(page) * kPageCells;
        for (int z = lo.z; z < hi.z; ++z)
          for (int y = lo.y; y < hi.y; ++y) std::fill_n(cells + (z * N + y) * N + lo.x, hi.x - lo.x, entry);
      }
  if (mKept) touch(b0, b1);
}

void CellTable::deferAll(const TraversalResult& visible, int brickSize) {
  const glm::ivec3 dims = mCells << mShift;
  for (const BrickDraw& d : visible.bricks) {
    const int m = int(d.key.level);
    const glm::ivec3 lo = glm::ivec3(int(d.key.i), int(d.key.j), int(d.key.k)) * (brickSize << m);
    const glm::ivec3 hi = glm::min(lo + (brickSize << m), dims);
    fill(lo >> mShift, (hi + ((1 << mShift) - 1)) >> mShift, kDeferred);
  }
  mBaseDirectory = mDirectory, mBasePool = mPool, mBaseFree = mFreePages, mBasePageCount = mPageCount;
}

void CellTable::deferOutside(const glm::ivec3& lo, const glm::ivec3& hi) {
  const glm::ivec3 c0 = lo >> mShift, c1 = glm::min((hi + ((1 << mShift) - 1)) >> mShift, mCells);
  const glm::ivec3 r0 = glm::max(c0 - 1, glm::ivec3(0)), r1 = glm::min(c1 + 1, mCells);
  // The shell between [r0, r1) and [c0, c1), as six slabs.
  for (int a = 0; a < 3; ++a) {
    glm::ivec3 s0 = r0, s1 = r1;
    for (int b = 0; b < a; ++b) s0[b] = c0[b], s1[b] = c1[b];  // earlier axes' slabs took their outside parts
    if (r0[a] < c0[a]) {
      glm::ivec3 t1 = s1;
      t1[a] = c0[a];
      fill(s0, t1, kDeferred);
    }
    if (c1[a] < r1[a]) {
      glm::ivec3 t0 = s0;
      t0[a] = c1[a];
      fill(t0, s1, kDeferred);
    }
  }
  mBaseDirectory = mDirectory, mBasePool = mPool, mBaseFree = mFreePages, mBasePageCount = mPageCount;
}

void CellTable::add(const QueuedBox& box) {
  constexpr int lo16 = std::numeric_limits<int16_t>::min(), hi16 = std::numeric_limits<int16_t>::max();
  for (int a = 0; a < 3; ++a)
    if (box.payload[a] < lo16 || box.payload[a] > hi16)
      throw RenderError("ray casting: atlas offset " + std::to_string(box.payload[a]) + " does not fit the cell table");
  const glm::ivec3 lo = box.ownLo >> mShift;
  const glm::ivec3 hi = glm::min((box.ownHi + ((1 << mShift) - 1)) >> mShift, mCells);
  fill(lo, hi, glm::i16vec4(box.payload));
  mMarked = mMarked || (lo.x < hi.x && lo.y < hi.y && lo.z < hi.z);
}

void CellTable::clear(const glm::ivec3& lo, const glm::ivec3& hi) {
  fill(glm::max(lo >> mShift, glm::ivec3(0)), glm::min((hi + ((1 << mShift) - 1)) >> mShift, mCells), kEmpty);
}

void CellTable::touch(const glm::ivec3& b0, const glm::ivec3& b1) {
  for (int z = b0.z; z < b1.z; ++z)
    for (int y = b0.y; y < b1.y; ++y) std::fill_n(mChanged.begin() + ptrdiff_t(blockIndex({b0.x, y, z})), b1.x - b0.x, 1);
  mChangedLo = glm::min(mChangedLo, b0), mChangedHi = glm::max(mChangedHi, b1);
}

void CellTable::settle(const glm::ivec3& b) {
  int32_t& page = mDirectory[blockIndex(b)];
  if (page < 0) return;
  if (computePageLeaps(mPool.data() + size_t(page) * kPageCells)) {
    mFreePages.push_back(page);
    page = kBlockNothing;
  }
}

bool CellTable::reservePool() {
  if (size_t(mPageCount) <= mPoolCapacity && mPoolBuffer) return false;
  // Grown by half again, so that a table growing page by page is copied a few times, not every frame.
  size_t capacity = std::max<size_t>({size_t(mPageCount), mPoolCapacity + mPoolCapacity / 2, 64});
  GLint limit = 0;
  mGl.glGetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &limit);
  capacity = std::min(capacity, size_t(limit) / kPageCells);
  if (capacity < size_t(mPageCount))
    throw RenderError("ray casting: the cell table needs " + std::to_string(mPageCount) + " pages of " +
                      std::to_string(kPageCells) + " cells, above this device's buffer texture limit of " +
                      std::to_string(limit) + " texels");
  mPoolBuffer = Buffer(mGl);
  mPoolBuffer.allocate(GL_TEXTURE_BUFFER, capacity * kPageCells * sizeof(glm::i16vec4), nullptr, GL_DYNAMIC_DRAW);
  mPoolCapacity = capacity;
  mPoolTexture = Texture(mGl, GL_TEXTURE_BUFFER);
  mPoolTexture.bind(VB_UNIT_CELLS);
  mGl.glTexBuffer(GL_TEXTURE_BUFFER, GL_RGBA16I, mPoolBuffer.id());
  return true;
}

int64_t CellTable::sendPages(std::vector<int32_t>& pages) {
  std::sort(pages.begin(), pages.end());
  mPoolBuffer.bind(GL_TEXTURE_BUFFER);
  constexpr size_t pageBytes = kPageCells * sizeof(glm::i16vec4);
  for (size_t i = 0; i < pages.size();) {
    size_t j = i + 1;
    while (j < pages.size() && pages[j] == pages[j - 1] + 1) ++j;
    mGl.glBufferSubData(GL_TEXTURE_BUFFER, GLintptr(size_t(pages[i]) * pageBytes), GLsizeiptr((j - i) * pageBytes),
                        mPool.data() + size_t(pages[i]) * kPageCells);
    i = j;
  }
  return int64_t(pages.size()) * kPageCells;
}

void CellTable::sendDirectoryRun(const glm::ivec3& b, int n) {
  mDirectoryTexture.bind(VB_UNIT_CELL_DIRECTORY);
  mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
  mGl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  mGl.glTexSubImage3D(GL_TEXTURE_3D, 0, b.x, b.y, b.z, n, 1, 1, GL_RED_INTEGER, GL_INT, &mDirectory[blockIndex(b)]);
}

void CellTable::bind() const {
  if (!mPaged) {
    mDenseTexture.bind(VB_UNIT_CELLS);
    return;
  }
  mDirectoryTexture.bind(VB_UNIT_CELL_DIRECTORY);
  mPoolTexture.bind(VB_UNIT_CELLS);
}

const glm::i16vec4* CellTable::blockCells(const glm::ivec3& b) const {
  static const std::vector<glm::i16vec4> nothing(kPageCells, glm::i16vec4(kMaxLeapLevel, 0, 0, kNothing));
  static const std::vector<glm::i16vec4> other(kPageCells, kDeferred);
  const int32_t page = mDirectory[blockIndex(b)];
  return page >= 0 ? mPool.data() + size_t(page) * kPageCells : page == kBlockNothing ? nothing.data() : other.data();
}

int64_t CellTable::sendDense() {
  mDense.resize(size_t(mCells.x) * size_t(mCells.y) * size_t(mCells.z));
  for (int bz = 0; bz < mBlocks.z; ++bz)
    for (int by = 0; by < mBlocks.y; ++by)
      for (int bx = 0; bx < mBlocks.x; ++bx) {
        const glm::ivec3 b(bx, by, bz), end = glm::min(mCells - b * N, glm::ivec3(N));
        const glm::i16vec4* cells = blockCells(b);
        for (int z = 0; z < end.z; ++z)
          for (int y = 0; y < end.y; ++y)
            std::copy_n(cells + (z * N + y) * N, end.x,
                        mDense.begin() + ptrdiff_t((size_t(b.z * N + z) * size_t(mCells.y) + size_t(b.y * N + y)) *
                                                       size_t(mCells.x) +
                                                   size_t(b.x * N)));
      }
  mDenseTexture.bind(VB_UNIT_CELLS);
  mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
  mGl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  mGl.glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, mCells.x, mCells.y, mCells.z, GL_RGBA_INTEGER, GL_SHORT,
                      mDense.data());
  return int64_t(mDense.size());
}

int64_t CellTable::sendDenseBlock(const glm::ivec3& b) {
  const glm::ivec3 end = glm::min(mCells - b * N, glm::ivec3(N));
  mDenseTexture.bind(VB_UNIT_CELLS);
  mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
  mGl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  mGl.glPixelStorei(GL_UNPACK_ROW_LENGTH, N);
  mGl.glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, N);
  mGl.glTexSubImage3D(GL_TEXTURE_3D, 0, b.x * N, b.y * N, b.z * N, end.x, end.y, end.z, GL_RGBA_INTEGER, GL_SHORT,
                      blockCells(b));
  mGl.glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  mGl.glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, 0);
  return int64_t(end.x) * end.y * end.z;
}

int64_t CellTable::upload() {
  for (int z = 0; z < mBlocks.z; ++z)
    for (int y = 0; y < mBlocks.y; ++y)
      for (int x = 0; x < mBlocks.x; ++x) settle({x, y, z});
  if (!mPaged) {
    const int64_t sent = sendDense();
    bind();
    reset();
    return sent;
  }
  reservePool();
  std::vector<int32_t> pages;
  for (int32_t page : mDirectory)
    if (page >= 0) pages.push_back(page);
  int64_t sent = sendPages(pages);
  mDirectoryTexture.bind(VB_UNIT_CELL_DIRECTORY);
  mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
  mGl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  mGl.glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, mBlocks.x, mBlocks.y, mBlocks.z, GL_RED_INTEGER, GL_INT,
                      mDirectory.data());
  sent += int64_t(mDirectory.size());
  bind();
  reset();
  return sent;
}

int64_t CellTable::uploadChanges() {
  std::vector<int32_t> pages;
  std::vector<glm::ivec3> blocks;
  for (int z = mChangedLo.z; z < mChangedHi.z; ++z)
    for (int y = mChangedLo.y; y < mChangedHi.y; ++y)
      for (int x = mChangedLo.x; x < mChangedHi.x; ++x)
        if (mChanged[blockIndex({x, y, z})]) {
          settle({x, y, z});
          blocks.push_back({x, y, z});
          if (const int32_t page = mDirectory[blockIndex({x, y, z})]; page >= 0) pages.push_back(page);
        }
  if (!mPaged) {
    // One grid: the changed blocks, or every cell at once when most changed.
    int64_t sent = 0;
    if (blocks.size() * 4 > mDirectory.size())
      sent = sendDense();
    else
      for (const glm::ivec3& b : blocks) sent += sendDenseBlock(b);
    std::fill(mChanged.begin(), mChanged.end(), 0);
    mChangedLo = mBlocks, mChangedHi = glm::ivec3(0);
    bind();
    return sent;
  }
  if (reservePool()) {  // a new buffer holds none of the pages yet: all of them
    pages.clear();
    for (int32_t page : mDirectory)
      if (page >= 0) pages.push_back(page);
  }
  int64_t sent = sendPages(pages);
  // Each row of blocks (along x) sends the directory entries from its first changed block to its last.
  for (int z = mChangedLo.z; z < mChangedHi.z; ++z)
    for (int y = mChangedLo.y; y < mChangedHi.y; ++y) {
      const uint8_t* row = &mChanged[blockIndex({0, y, z})];
      int first = mChangedLo.x, last = mChangedHi.x - 1;
      while (first <= last && !row[first]) ++first;
      while (last >= first && !row[last]) --last;
      if (first > last) continue;
      sendDirectoryRun({first, y, z}, last + 1 - first);
      sent += last + 1 - first;
    }
  std::fill(mChanged.begin(), mChanged.end(), 0);
  mChangedLo = mBlocks, mChangedHi = glm::ivec3(0);
  bind();
  return sent;
}

void CellTable::reset() {
  if (mBaseDirectory.empty()) {
    std::fill(mDirectory.begin(), mDirectory.end(), kBlockNothing);
    mPool.clear();
    mFreePages.clear();
    mPageCount = 0;
  } else {
    mDirectory = mBaseDirectory, mPool = mBasePool, mFreePages = mBaseFree, mPageCount = mBasePageCount;
  }
  mMarked = false;
}

std::vector<glm::i16vec4> CellTable::readBack() const {
  if (!mPaged) {
    std::vector<glm::i16vec4> cells(size_t(mCells.x) * size_t(mCells.y) * size_t(mCells.z));
    mDenseTexture.bind(VB_UNIT_CELLS);
    mGl.glPixelStorei(GL_PACK_ALIGNMENT, 4);
    mGl.glGetTexImage(GL_TEXTURE_3D, 0, GL_RGBA_INTEGER, GL_SHORT, cells.data());
    return cells;
  }
  std::vector<int32_t> directory(mDirectory.size());
  mDirectoryTexture.bind(VB_UNIT_CELL_DIRECTORY);
  mGl.glPixelStorei(GL_PACK_ALIGNMENT, 4);
  mGl.glGetTexImage(GL_TEXTURE_3D, 0, GL_RED_INTEGER, GL_INT, directory.data());
  std::vector<glm::i16vec4> pool(mPoolCapacity * kPageCells);
  if (!pool.empty()) mPoolBuffer.read(0, pool.size() * sizeof(glm::i16vec4), pool.data());
  std::vector<glm::i16vec4> cells(size_t(mCells.x) * size_t(mCells.y) * size_t(mCells.z));
  for (int z = 0; z < mCells.z; ++z)
    for (int y = 0; y < mCells.y; ++y)
      for (int x = 0; x < mCells.x; ++x) {
        const glm::ivec3 c(x, y, z), b = c / N, l = c - b * N;
        const int32_t page = directory[blockIndex(b)];
        cells[(size_t(z) * size_t(mCells.y) + size_t(y)) * size_t(mCells.x) + size_t(x)] =
            page == kBlockNothing      ? glm::i16vec4(kMaxLeapLevel, 0, 0, kNothing)
            : page == kBlockOtherBatch ? kDeferred
                                       : pool[size_t(page) * kPageCells + size_t((l.z * N + l.y) * N + l.x)];
      }
  return cells;
}

bool computePageLeaps(glm::i16vec4* page) {
  // Which aligned sub-blocks of 2^j cells have nothing to draw, level by level: empty[j] holds (N >> j)^3 flags.
  bool empty[CellTable::kMaxLeapLevel + 1][CellTable::kPageCells];
  for (int i = 0; i < CellTable::kPageCells; ++i) empty[0][i] = page[i].w == CellTable::kNothing;
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
  for (int z = 0; z < N; ++z)
    for (int y = 0; y < N; ++y)
      for (int x = 0; x < N; ++x) {
        glm::i16vec4& cell = page[(z * N + y) * N + x];
        if (cell.w != CellTable::kNothing) continue;
        // The largest empty block around it: the blocks nest, so the coarsest empty level is the one.
        int leap = 0;
        for (int j = CellTable::kMaxLeapLevel; j > 0 && leap == 0; --j) {
          const int n = N >> j;
          if (empty[j][((z >> j) * n + (y >> j)) * n + (x >> j)]) leap = j;
        }
        cell.x = int16_t(leap);
      }
  return empty[CellTable::kMaxLeapLevel][0];
}

}  // namespace voxbrick::render
