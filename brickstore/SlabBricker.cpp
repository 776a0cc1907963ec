// Slab-by-slab bricking: the window holds slices z0-1 .. z0+B of the slab being cut, edges clamped.
#include "brickstore/SlabBricker.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstring>

#include "brickstore/Codec.h"

namespace voxbrick::store {

int64_t SlabBricker::windowBytes(const Vec3i& dims, int brickSize, ValueType type) {
  return (brickSize + 2) * dims.x * dims.y * static_cast<int64_t>(valueSize(type));
}

LevelBuild SlabBricker::run() {
  return dispatchType(mSource.info().type, [this](auto tag) { return runTyped<decltype(tag)>(); });
}

template <typename T>
LevelBuild SlabBricker::runTyped() {
  const Vec3i n = mSource.info().dims;
  const int64_t B = mBrickSize, E = B + 2;
  const int64_t sliceValues = n.x * n.y;
  const T background = static_cast<T>(mBackground);

  LevelBuild level;
  level.dims = n;
  level.bricks = {divUp(n.x, B), divUp(n.y, B), divUp(n.z, B)};
  level.records.assign(static_cast<size_t>(level.bricks.volume()), BrickRecord{});

  // Slot s of the window holds slice z = kz*B - 1 + s of slab kz, clamped to [0, n.z - 1].
  std::vector<T> window(static_cast<size_t>(E * sliceValues));
  auto slot = [&](int64_t s) { return window.data() + s * sliceValues; };
  int64_t nextZ = 0;
  auto readInto = [&](int64_t firstSlot, int64_t count) {
    mSource.readSlices(count, slot(firstSlot));
    if (mSliceHook) mSliceHook(nextZ, count, slot(firstSlot));
    nextZ += count;
  };

  const int64_t slabBricks = level.bricks.x * level.bricks.y;
  std::vector<std::vector<char>> frames(static_cast<size_t>(slabBricks));
  std::vector<MinMaxPair> ranges(static_cast<size_t>(slabBricks));

  for (int64_t kz = 0; kz < level.bricks.z; ++kz) {
    int64_t lastReal;
    if (kz == 0) {
      int64_t count = std::min(n.z, B + 1);
      readInto(1, count);
      std::memcpy(slot(0), slot(1), sizeof(T) * static_cast<size_t>(sliceValues));
      lastReal = count;
    } else {
      std::memmove(slot(0), slot(B), sizeof(T) * static_cast<size_t>(2 * sliceValues));
      int64_t count = std::min(n.z - nextZ, B);
      if (count > 0) readInto(2, count);
      lastReal = 1 + count;
    }
    for (int64_t s = lastReal + 1; s < E; ++s)
      std::memcpy(slot(s), slot(lastReal), sizeof(T) * static_cast<size_t>(sliceValues));

    tbb::parallel_for(tbb::blocked_range<int64_t>(0, slabBricks), [&](const tbb::blocked_range<int64_t>& r) {
      std::vector<T> brick(static_cast<size_t>(E * E * E));
      for (int64_t b = r.begin(); b != r.end(); ++b) {
        const int64_t bi = b % level.bricks.x, bj = b / level.bricks.x;
        T* dst = brick.data();
        for (int64_t c = 0; c < E; ++c) {
          const T* plane = slot(c);
          for (int64_t yb = 0; yb < E; ++yb) {
            int64_t y = std::clamp<int64_t>(bj * B + yb - 1, 0, n.y - 1);
            const T* row = plane + y * n.x;
            const int64_t x0 = bi * B - 1;
            if (x0 >= 0 && x0 + E <= n.x) {
              std::memcpy(dst, row + x0, sizeof(T) * static_cast<size_t>(E));
              dst += E;
            } else {
              for (int64_t xa = 0; xa < E; ++xa) *dst++ = row[std::clamp<int64_t>(x0 + xa, 0, n.x - 1)];
            }
          }
        }
        bool empty = true;
        ranges[static_cast<size_t>(b)] = sampleRange(brick.data(), brick.size(), background, empty);
        std::vector<char>& frame = frames[static_cast<size_t>(b)];
        if (empty)
          frame.clear();
        else
          compressFrame(brick.data(), brick.size() * sizeof(T), sizeof(T), mZstdLevel, frame);
      }
    });

    // Frames go out in brick order so that the same input always gives the same file.
    for (int64_t b = 0; b < slabBricks; ++b) {
      BrickRecord& rec = level.records[static_cast<size_t>(b + slabBricks * kz)];
      const std::vector<char>& frame = frames[static_cast<size_t>(b)];
      rec.min = ranges[static_cast<size_t>(b)].min;
      rec.max = ranges[static_cast<size_t>(b)].max;
      if (!frame.empty()) {
        rec.offset = mOut.append(frame.data(), frame.size());
        rec.compressedSize = static_cast<uint32_t>(frame.size());
        level.bricksStored += 1;
        level.bytesStored += static_cast<int64_t>(frame.size());
      }
    }
    if (mProgressHook) mProgressHook(kz + 1, level.bricks.z);
  }
  return level;
}

}  // namespace voxbrick::store
