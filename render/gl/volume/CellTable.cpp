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

void CellTable::begin(const glm::ivec3& dims, int cellSize) {
  const glm::ivec3 cells(cellsAlong(dims.x, cellSize), cellsAlong(dims.y, cellSize), cellsAlong(dims.z, cellSize));
  mShift = std::countr_zero(unsigned(cellSize));
  if (cells != mCells || !mTexture) {
    mCells = cells;
    mTexture = Texture(mGl, GL_TEXTURE_3D);
    mTexture.bind(VB_UNIT_CELLS);
    mGl.glTexStorage3D(GL_TEXTURE_3D, 1, GL_RGBA16I, cells.x, cells.y, cells.z);
    mGl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    mGl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  }
  mDeferred.clear();
  mHost.assign(size_t(cells.x) * size_t(cells.y) * size_t(cells.z), kEmpty);
  mMarked = false;
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
  mMarked = mMarked || (lo.x < hi.x && lo.y < hi.y && lo.z < hi.z);
}

void CellTable::upload() {
  computeLeaps(mHost, mCells, mScratch);
  mTexture.bind(VB_UNIT_CELLS);
  mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
  mGl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  mGl.glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, mCells.x, mCells.y, mCells.z, GL_RGBA_INTEGER, GL_SHORT, mHost.data());
  reset();
}

void CellTable::reset() {
  if (mDeferred.empty())
    std::fill(mHost.begin(), mHost.end(), kEmpty);
  else
    for (size_t i = 0; i < mHost.size(); ++i) mHost[i] = mDeferred[i] ? kDeferred : kEmpty;
  mMarked = false;
}

void computeLeaps(std::vector<glm::i16vec4>& cells, const glm::ivec3& grid, std::vector<uint8_t>& scratch) {
  // Level by level, which aligned blocks of 2^j cells have nothing to draw, in place in `scratch`: block (x, y, z)
  // of level j reads its children at (2x.., 2y.., 2z..) of level j - 1, which lie at or after it in x-fastest
  // order, and every block read later lies after it too, so no child is overwritten before it is read.
  auto cell = [&](const glm::ivec3& dims, int x, int y, int z) {
    return (size_t(z) * size_t(dims.y) + size_t(y)) * size_t(dims.x) + size_t(x);
  };
  scratch.resize(cells.size());
  for (size_t i = 0; i < cells.size(); ++i) scratch[i] = cells[i].w == CellTable::kNothing;
  glm::ivec3 blocks = grid;
  for (int j = 1; j <= CellTable::kMaxLeapLevel; ++j) {
    const glm::ivec3 finer = blocks;
    blocks = (finer + 1) >> 1;
    bool any = false;
    for (int z = 0; z < blocks.z; ++z)
      for (int y = 0; y < blocks.y; ++y)
        for (int x = 0; x < blocks.x; ++x) {
          bool empty = true;
          for (int c = 0; c < 8 && empty; ++c) {
            const int cx = 2 * x + (c & 1), cy = 2 * y + ((c >> 1) & 1), cz = 2 * z + (c >> 2);
            empty = cx >= finer.x || cy >= finer.y || cz >= finer.z || scratch[cell(finer, cx, cy, cz)];
          }
          scratch[cell(blocks, x, y, z)] = empty;
          any = any || empty;
        }
    if (!any) break;
    for (int z = 0; z < grid.z; ++z)
      for (int y = 0; y < grid.y; ++y)
        for (int x = 0; x < grid.x; ++x)
          if (scratch[cell(blocks, x >> j, y >> j, z >> j)]) cells[cell(grid, x, y, z)].x = int16_t(j);
  }
}

}  // namespace voxbrick::render
