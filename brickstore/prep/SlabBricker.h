// Cuts one level of a volume, streamed z-slice by z-slice, into bordered bricks and appends their zstd frames.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "brickstore/format/BrickFile.h"
#include "brickstore/format/BrickMath.h"
#include "brickstore/format/StoreFormat.h"
#include "brickstore/source/VolumeSource.h"
#include "common/OutputFile.h"

namespace voxbrick::store {

/// The bricks of one level as written: records indexed i + bricks.x * (j + bricks.y * k).
struct LevelBuild {
  Vec3i dims;
  Vec3i bricks;
  std::vector<BrickRecord> records;
  int64_t bricksStored = 0;
  int64_t bytesStored = 0;
};

/// Reads a source once, in z order, through a window of B + 2 slices (so memory is bounded by the slice size,
/// not the volume), and writes every non-empty brick of the level as a zstd frame to `out`.
///
/// The work runs as a pipeline of three stages over slabs of bricks: read (the source, then the slice hook), cut
/// (the slice consumer beside cutting, taking the min/max of and compressing every brick in parallel) and write
/// (frames appended in brick order). With `slabsInFlight` > 1 each slab in flight has its own window, so reading
/// the next slab overlaps cutting this one; the bytes written never depend on it.
class SlabBricker {
 public:
  /// Called with each batch of real slices right after it is read (z of the first, count, the values); it may
  /// modify them (the non-finite policy does) before they are bricked. Runs in z order, one batch at a time.
  using SliceHook = std::function<void(int64_t z0, int64_t count, void* values)>;
  /// Called with each slab's slices (z0 = kz * B, B of them, fewer in the last) while the slab is being cut (so it
  /// must only read them), after the slice hook has seen them; runs in z order, one slab at a time.
  using SliceConsumer = std::function<void(int64_t z0, int64_t count, const void* values)>;
  /// Called after each slab of bricks with (slabs done, slabs in all).
  using ProgressHook = std::function<void(int64_t done, int64_t total)>;

  SlabBricker(VolumeSource& source, int brickSize, double background, int zstdLevel, common::OutputFile& out)
      : mSource(source), mBrickSize(brickSize), mBackground(background), mZstdLevel(zstdLevel), mOut(out) {}

  void setSliceHook(SliceHook hook) { mSliceHook = std::move(hook); }
  void setSliceConsumer(SliceConsumer consumer) { mSliceConsumer = std::move(consumer); }
  /// Slabs in flight at once (>= 1; default 1): each holds slabBytes() of memory.
  void setSlabsInFlight(int slabs) { mSlabsInFlight = slabs < 1 ? 1 : slabs; }
  void setProgressHook(ProgressHook hook) { mProgressHook = std::move(hook); }

  /// Bricks the whole source. Throws what the source or the output throws.
  LevelBuild run();

  /// Bytes the window holds for a level of `dims`, for memory planning.
  static int64_t windowBytes(const Vec3i& dims, int brickSize, ValueType type);
  /// Bytes one slab in flight may hold for a level of `dims`: its window and its compressed frames (counted as
  /// large as the bricks they encode, borders included, plus zstd's bound).
  static int64_t slabBytes(const Vec3i& dims, int brickSize, ValueType type);

 private:
  template <typename T>
  LevelBuild runTyped();

  VolumeSource& mSource;
  int mBrickSize;
  double mBackground;
  int mZstdLevel;
  common::OutputFile& mOut;
  SliceHook mSliceHook;
  SliceConsumer mSliceConsumer;
  ProgressHook mProgressHook;
  int mSlabsInFlight = 1;
};

}  // namespace voxbrick::store
