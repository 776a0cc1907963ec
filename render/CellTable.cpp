// Marking and uploading the cells of a batch.
#include "render/CellTable.h"

#include <algorithm>
#include <bit>
#include <limits>

#include "render/RenderErrors.h"
#include "render/SlicingPass.h"
#include "render/Traversal.h"

namespace voxbrick::render {
namespace {

const glm::i16vec4 kEmpty(0, 0, 0, CellTable::kNothing);
const glm::i16vec4 kDeferred(0, 0, 0, CellTable::kOtherBatch);

int cellsAlong(int voxels, int cellSize) { return (voxels + cellSize - 1) / cellSize; }

}  // namespace

int64_t CellTable::cellCount(const glm::ivec3& dims, int cellSize) {
  return int64_t(cellsAlong(dims.x, cellSize)) * cellsAlong(dims.y, cellSize) * cellsAlong(dims.z, cellSize);
}

void CellTable::begin(const glm::ivec3& dims, int cellSize) {
  const glm::ivec3 cells(cellsAlong(dims.x, cellSize), cellsAlong(dims.y, cellSize), cellsAlong(dims.z, cellSize));
  mShift = std::countr_zero(unsigned(cellSize));
  if (cells != mCells || !mTexture) {
    mCells = cells;
    mHost.assign(size_t(cells.x) * size_t(cells.y) * size_t(cells.z), kEmpty);
    mTexture = Texture(mGl, GL_TEXTURE_3D);
    mTexture.bind(4);
    mGl.glTexStorage3D(GL_TEXTURE_3D, 1, GL_RGBA16I, cells.x, cells.y, cells.z);
    mGl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    mGl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    mUploadedLo = 0;  // the new texture's contents are undefined: clear all of it at the first upload
    mUploadedHi = cells.z - 1;
  } else {
    clearLayers(mTouchedLo, mTouchedHi);  // a frame that failed before its upload
  }
  mTouchedLo = 1;
  mTouchedHi = 0;
  if (!mDeferred.empty()) {
    // The previous frame's deferred cells: back to nothing, and uploaded so at the first batch.
    std::fill(mHost.begin(), mHost.end(), kEmpty);
    mDeferred.clear();
    mUploadedLo = 0;
    mUploadedHi = mCells.z - 1;
  }
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
      for (int y = c0.y; y < c1.y; ++y) {
        std::fill_n(mDeferred.begin() + ptrdiff_t(index(c0.x, y, z)), c1.x - c0.x, uint8_t(1));
        std::fill_n(mHost.begin() + ptrdiff_t(index(c0.x, y, z)), c1.x - c0.x, kDeferred);
      }
  }
  mUploadedLo = 0;  // the whole table goes up with the first batch
  mUploadedHi = mCells.z - 1;
}

void CellTable::clearLayers(int lo, int hi) {
  lo = std::max(lo, 0);
  hi = std::min(hi, mCells.z - 1);
  if (lo > hi) return;
  const size_t begin = index(0, 0, lo), end = index(0, 0, hi + 1);
  if (mDeferred.empty()) {
    std::fill(mHost.begin() + ptrdiff_t(begin), mHost.begin() + ptrdiff_t(end), kEmpty);
    return;
  }
  for (size_t i = begin; i < end; ++i) mHost[i] = mDeferred[i] ? kDeferred : kEmpty;
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
  if (lo.z < hi.z) {
    mTouchedLo = empty() ? lo.z : std::min(mTouchedLo, lo.z);
    mTouchedHi = std::max(mTouchedHi, hi.z - 1);
  }
}

void CellTable::upload() {
  // The layers to write: this batch's marks, and the previous batch's, which must be cleared.
  const int lo = mUploadedLo <= mUploadedHi ? std::min(mUploadedLo, mTouchedLo) : mTouchedLo;
  const int hi = mUploadedLo <= mUploadedHi ? std::max(mUploadedHi, mTouchedHi) : mTouchedHi;
  mTexture.bind(4);
  if (lo <= hi) {
    mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    mGl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    mGl.glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, lo, mCells.x, mCells.y, hi - lo + 1, GL_RGBA_INTEGER, GL_SHORT,
                        mHost.data() + index(0, 0, lo));
  }
  mUploadedLo = mTouchedLo;
  mUploadedHi = mTouchedHi;
  clearLayers(mTouchedLo, mTouchedHi);
  mTouchedLo = 1;
  mTouchedHi = 0;
}

}  // namespace voxbrick::render
