// Slab-by-slab bricking: the window holds slices z0-1 .. z0+B of the slab being cut, edges clamped.
#include "brickstore/prep/SlabBricker.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_pipeline.h>

#include <algorithm>
#include <cstring>

namespace voxbrick::store {

int64_t SlabBricker::windowBytes(const Vec3i& dims, int brickSize, ValueType type) {
  return (brickSize + 2) * dims.x * dims.y * static_cast<int64_t>(valueSize(type));
}

int64_t SlabBricker::slabBytes(const Vec3i& dims, int brickSize, ValueType type) {
  const int64_t window = windowBytes(dims, brickSize, type), B = brickSize;
  return window + window * (B + 2) * (B + 2) / (B * B) + (int64_t{64} << 10);
}

LevelBuild SlabBricker::run() {
  return dispatchType(mSource.info().type, [this](auto tag) { return runTyped<decltype(tag)>(); });
}

namespace {

/// One slab in flight: its window and, once cut, its bricks' ranges and frames.
template <typename T>
struct Slab {
  int64_t kz = 0;
  int64_t z0 = 0, count = 0;  // the real slices it read: z of the first, how many, from window slot `firstSlot`
  int64_t firstSlot = 0;
  std::vector<T> window;
  std::vector<MinMaxPair> ranges;
  std::vector<std::vector<char>> frames;
};

/// Cuts brick (bi, bj) of a slab out of its window (slot s = z0 - 1 + s, x and y clamped) into dst.
template <typename T>
void cutBrick(const T* window, const Vec3i& n, int64_t B, int64_t bi, int64_t bj, T* dst) {
  const int64_t E = B + 2, sliceValues = n.x * n.y;
  for (int64_t c = 0; c < E; ++c) {
    const T* plane = window + c * sliceValues;
    for (int64_t yb = 0; yb < E; ++yb) {
      const int64_t y = std::clamp<int64_t>(bj * B + yb - 1, 0, n.y - 1);
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
}

/// Reads slab `slab.kz` into its window: slot s holds slice z = kz*B - 1 + s, clamped to [0, n.z - 1]. The first
/// two slots come from `previous`'s last two (none for the first slab); `nextZ` is the next slice of the source.
template <typename T>
void readSlab(Slab<T>& slab, const Slab<T>* previous, VolumeSource& source, const SlabBricker::SliceHook& hook,
              int64_t B, int64_t& nextZ) {
  const Vec3i n = source.info().dims;
  const int64_t E = B + 2, sliceValues = n.x * n.y;
  const size_t sliceBytes = sizeof(T) * static_cast<size_t>(sliceValues);
  T* window = slab.window.data();
  auto slot = [&](int64_t s) { return window + s * sliceValues; };
  slab.z0 = nextZ;
  if (!previous) {
    slab.count = std::min(n.z, B + 1);
    slab.firstSlot = 1;
  } else {
    std::memmove(slot(0), previous->window.data() + B * sliceValues, 2 * sliceBytes);
    slab.count = std::min(n.z - nextZ, B);
    slab.firstSlot = 2;
  }
  if (slab.count > 0) {
    source.readSlices(slab.count, slot(slab.firstSlot));
    if (hook) hook(slab.z0, slab.count, slot(slab.firstSlot));
  }
  nextZ += slab.count;
  if (!previous) std::memcpy(slot(0), slot(1), sliceBytes);
  const int64_t lastReal = slab.firstSlot + slab.count - 1;
  for (int64_t s = lastReal + 1; s < E; ++s) std::memcpy(slot(s), slot(lastReal), sliceBytes);
}

/// Cuts every brick of a slab out of its window in parallel, taking its value range and, unless it holds only the
/// background, its zstd frame.
template <typename T>
void cutBricks(Slab<T>& slab, const Vec3i& n, int64_t B, const Vec3i& bricks, T background, int zstdLevel) {
  const int64_t E = B + 2;
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, bricks.x * bricks.y), [&](const tbb::blocked_range<int64_t>& r) {
    thread_local std::vector<T> brick;
    brick.resize(static_cast<size_t>(E * E * E));
    for (int64_t b = r.begin(); b != r.end(); ++b) {
      cutBrick(slab.window.data(), n, B, b % bricks.x, b / bricks.x, brick.data());
      bool empty = true;
      slab.ranges[static_cast<size_t>(b)] = sampleRange(brick.data(), brick.size(), background, empty);
      std::vector<char>& frame = slab.frames[static_cast<size_t>(b)];
      if (empty)
        frame.clear();
      else
        compressFrame(brick.data(), brick.size() * sizeof(T), sizeof(T), zstdLevel, frame);
    }
  });
}

/// Appends a slab's frames to `out` in brick order, so that the same input always gives the same file, and fills
/// their records in `level`.
template <typename T>
void writeSlab(const Slab<T>& slab, LevelBuild& level, common::OutputFile& out) {
  const int64_t slabBricks = level.bricks.x * level.bricks.y;
  for (int64_t b = 0; b < slabBricks; ++b) {
    BrickRecord& rec = level.records[static_cast<size_t>(b + slabBricks * slab.kz)];
    const std::vector<char>& frame = slab.frames[static_cast<size_t>(b)];
    rec.min = slab.ranges[static_cast<size_t>(b)].min;
    rec.max = slab.ranges[static_cast<size_t>(b)].max;
    if (!frame.empty()) {
      rec.offset = out.append(frame.data(), frame.size());
      rec.compressedSize = static_cast<uint32_t>(frame.size());
      level.bricksStored += 1;
      level.bytesStored += static_cast<int64_t>(frame.size());
    }
  }
}

}  // namespace

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
  const int64_t slabBricks = level.bricks.x * level.bricks.y;

  // The slabs in flight take turns through a ring: slab kz uses slabs[kz % ring]; the pipeline admits no more
  // than `ring` at once, so the one it replaces has been written, and the one before it (whose last two slices
  // become this window's first two) is still there.
  const int64_t ring = std::min<int64_t>(mSlabsInFlight, level.bricks.z);
  std::vector<Slab<T>> slabs(static_cast<size_t>(ring));
  for (Slab<T>& slab : slabs) {
    slab.window.resize(static_cast<size_t>(E * sliceValues));
    slab.ranges.resize(static_cast<size_t>(slabBricks));
    slab.frames.resize(static_cast<size_t>(slabBricks));
  }
  int64_t nextZ = 0, nextSlab = 0;

  // Stage 1, in order: the source's slices into the slab's window.
  auto read = [&](tbb::flow_control& fc) -> Slab<T>* {
    if (nextSlab == level.bricks.z) {
      fc.stop();
      return nullptr;
    }
    const int64_t kz = nextSlab++;
    Slab<T>& slab = slabs[static_cast<size_t>(kz % ring)];
    slab.kz = kz;
    readSlab(slab, kz == 0 ? nullptr : &slabs[static_cast<size_t>((kz - 1) % ring)], mSource, mSliceHook, B, nextZ);
    return &slab;
  };

  // Stage 2, in order (for the consumer): the consumer beside the bricks, which are cut and compressed in parallel.
  auto cut = [&](Slab<T>* slab) -> Slab<T>* {
    auto bricks = [&] { cutBricks(*slab, n, B, level.bricks, background, mZstdLevel); };
    // The consumer gets the slab's own slices, kz*B .. kz*B+B-1 (window slots 1 .. B, all read and through the
    // hook by now), not the batch read: batches aligned to B keep OpenVDB's 8^3 leaves whole.
    const int64_t z0 = slab->kz * B, count = std::min(B, n.z - z0);
    if (mSliceConsumer && count > 0) {
      const T* first = slab->window.data() + sliceValues;
      tbb::parallel_invoke([&] { mSliceConsumer(z0, count, first); }, bricks);
    } else {
      bricks();
    }
    return slab;
  };

  // Stage 3, in order: the frames appended.
  auto write = [&](Slab<T>* slab) {
    writeSlab(*slab, level, mOut);
    if (mProgressHook) mProgressHook(slab->kz + 1, level.bricks.z);
  };

  tbb::parallel_pipeline(static_cast<size_t>(ring),
                         tbb::make_filter<void, Slab<T>*>(tbb::filter_mode::serial_in_order, read) &
                             tbb::make_filter<Slab<T>*, Slab<T>*>(tbb::filter_mode::serial_in_order, cut) &
                             tbb::make_filter<Slab<T>*, void>(tbb::filter_mode::serial_in_order, write));
  return level;
}

}  // namespace voxbrick::store
