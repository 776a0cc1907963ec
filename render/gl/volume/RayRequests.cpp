// The rays' feedback buffer: a bit per level-0 brick, cleared before the frame and read back after it.
#include "render/gl/volume/RayRequests.h"

#include <algorithm>

#include "render/gl/Bindings.h"
#include "render/gl/volume/VolumePrograms.h"

namespace voxbrick::render {

RayRequests::RayRequests(const Gl& gl) : mGl(gl), mBuffer(gl) {}

int RayRequests::standInLevel(const store::BrickStore& store) {
  const int last = store.levelCount() - 1;
  for (int level = 1; level < last; ++level)
    if (store.level(level).bricksTotal() <= kStandInLevelBricks) return level;
  return last;
}

bool RayRequests::fits(const store::BrickStore& store) {
  return store.levelCount() > 1 && store.level(0).bricksTotal() <= kMaxBricks;
}

void RayRequests::begin(const store::BrickStore& store, const VolumeProgram& program) {
  const store::Vec3i& bricks = store.level(0).bricks;
  const glm::ivec3 grid(int(bricks.x), int(bricks.y), int(bricks.z));
  if (grid != mGrid || store.brickSize() != mBrickSize) {
    forget();
    mGrid = grid;
    mBrickSize = store.brickSize();
  }
  // The count, then the bits. A buffer whose last frame requested nothing is still all zeros.
  const size_t words = 1 + (size_t(store.level(0).bricksTotal()) + 31) / 32;
  if (mZero.size() != words) {
    mZero.assign(words, 0);
    mBuffer.allocate(GL_SHADER_STORAGE_BUFFER, words * sizeof(uint32_t), mZero.data(), GL_DYNAMIC_COPY);
  } else if (mDirty) {
    mBuffer.bind(GL_SHADER_STORAGE_BUFFER);
    mGl.glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(words * sizeof(uint32_t)), mZero.data());
  }
  mDirty = true;  // until read() finds the frame requested nothing (a frame given up is never read)
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_RAY_REQUESTS, mBuffer.id());
  program.setRequestGrid(glm::ivec4(mGrid, mBrickSize));
}

bool RayRequests::requested(const store::BrickKey& key) const {
  if (mRequestedCount == 0) return false;
  // The level-0 bricks under `key`: a block of 2^level a side, cut to the grid.
  const int side = 1 << key.level;
  const glm::ivec3 lo = glm::ivec3(int(key.i), int(key.j), int(key.k)) * side;
  const glm::ivec3 hi = glm::min(lo + side, mGrid);
  for (int z = lo.z; z < hi.z; ++z)
    for (int y = lo.y; y < hi.y; ++y)
      for (int x = lo.x; x < hi.x; ++x) {
        const size_t index = (size_t(z) * size_t(mGrid.y) + size_t(y)) * size_t(mGrid.x) + size_t(x);
        if (1 + index / 32 < mBits.size() && (mBits[1 + index / 32] >> (index % 32) & 1u)) return true;
      }
  return false;
}

void RayRequests::read(FrameStats& stats) {
  // The fragment kernel's buffer writes are made visible to the copy; the compute kernel's barriers already do.
  mGl.glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  // The count first: the bits only when there are any.
  uint32_t count = 0;
  if (!mZero.empty()) mBuffer.read(0, sizeof(count), &count);
  mRequestedCount = count;
  mDirty = count > 0;
  mBits.clear();
  if (count > 0) {
    mBits.resize(mZero.size());
    mBuffer.read(0, mBits.size() * sizeof(uint32_t), mBits.data());
  }
  stats.bricksRequested = mRequestedCount;
  stats.bricksUntouched =
      std::count_if(mStandIns.begin(), mStandIns.end(), [&](const store::BrickKey& key) { return !requested(key); });
}

void RayRequests::forget() {
  mBits.clear();
  mRequestedCount = 0;
  mStandIns.clear();
}

}  // namespace voxbrick::render
