// Sources used to build the LOD pyramid: a written level read back in z order, and its 2x2x2 downsample.
#pragma once

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <memory>
#include <type_traits>
#include <vector>

#include "brickstore/format/BrickFile.h"
#include "brickstore/prep/SlabBricker.h"
#include "brickstore/source/ByteStream.h"
#include "brickstore/source/VolumeSource.h"
#include "common/OutputFile.h"

namespace voxbrick::store {

/// A level that was just written, read back slice by slice by decoding one slab of bricks at a time, so memory
/// stays at one slab however large the level is.
class StoredLevelSource : public VolumeSource {
 public:
  /// `hook`, if set, sees every slice batch delivered (the histogram pass uses it).
  StoredLevelSource(const BrickFileReader& file, const LevelBuild& level, uint32_t levelIndex, int brickSize,
                    ValueType type, double background, Vec3d spacing);

  const VolumeInfo& info() const override { return mInfo; }
  void readSlices(int64_t count, void* dst) override;
  /// The next `count` slices in place, as readSlices would copy them (the hook sees them likewise), if they lie in
  /// one slab of bricks (valid until the next call); else null, and nothing is read.
  const void* nextSlicesInPlace(int64_t count);
  void setSliceHook(std::function<void(int64_t z0, int64_t count, const void* values)> hook) {
    mHook = std::move(hook);
  }

 private:
  void loadSlab(int64_t kz);

  const BrickFileReader& mFile;
  const LevelBuild& mLevel;
  uint32_t mLevelIndex;
  int mBrickSize;
  VolumeInfo mInfo;
  std::vector<char> mSlab;  // B slices of the level
  int64_t mSlabLoaded = -1;
  int64_t mNextZ = 0;
  std::function<void(int64_t, int64_t, const void*)> mHook;
};

/// Level k+1 from level k: voxel m averages voxels 2m and 2m+1 of the finer level along each axis (the second
/// clamped to the last voxel when the finer size is odd), 8 values in all. Integer types round half up.
class DownsampleSource : public VolumeSource {
 public:
  explicit DownsampleSource(VolumeSource& fine);

  const VolumeInfo& info() const override { return mInfo; }
  void readSlices(int64_t count, void* dst) override;

 private:
  template <typename T>
  void readTyped(int64_t count, T* dst);

  VolumeSource& mFine;
  StoredLevelSource* mStored;  // mFine, when it is a stored level: its slices are read in place
  VolumeInfo mInfo;
  std::vector<char> mPair;  // two finer slices
  int64_t mNextZ = 0;
};

/// Level 1 made while level 0 streams past (so level 0 need not be read back): each batch of level-0 slices is
/// downsampled exactly as DownsampleSource would (downsampleVoxel, brickstore/format/BrickMath.h) and its level-1
/// slices appended, in host order, to a scratch file that spilled() then reads back in z order. Holds one level-1 slice
/// in memory.
class Level1Spill {
 public:
  /// Level 0 of `fine` (its dims, type and background); the scratch file at `path` is created (and truncated).
  Level1Spill(const VolumeInfo& fine, std::filesystem::path path);

  /// The next `count` slices of level 0 from z0, in z order: z0 even, count even unless they end level 0.
  void addSlices(int64_t z0, int64_t count, const void* values);
  /// Level 1 as a source, once every slice of level 0 was added; it reads the scratch file (remove() it after).
  std::unique_ptr<VolumeSource> spilled() const;
  const std::filesystem::path& path() const { return mPath; }

 private:
  template <typename T>
  void addTyped(int64_t z0, int64_t count, const T* values);

  VolumeInfo mFine, mCoarse;
  std::filesystem::path mPath;
  common::OutputFile mFile;
  std::vector<char> mSlice;  // one level-1 slice
  int64_t mNextZ = 0;        // next level-0 slice expected
};

}  // namespace voxbrick::store
