// Reading a written level back in z order, and downsampling it, for the LOD pyramid and the histogram pass.
#include "brickstore/prep/LevelSources.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <cstring>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {

StoredLevelSource::StoredLevelSource(const BrickFileReader& file, const LevelBuild& level, uint32_t levelIndex,
                                     int brickSize, ValueType type, double background, Vec3d spacing)
    : mFile(file), mLevel(level), mLevelIndex(levelIndex), mBrickSize(brickSize) {
  mInfo.dims = level.dims;
  mInfo.spacing = spacing;
  mInfo.type = type;
  mInfo.background = background;
  mInfo.description = "level " + std::to_string(levelIndex) + " of the store being written";
  mSlab.resize(static_cast<size_t>(brickSize * level.dims.x * level.dims.y) * valueSize(type));
}

void StoredLevelSource::loadSlab(int64_t kz) {
  const Vec3i n = mLevel.dims, nb = mLevel.bricks;
  const int64_t B = mBrickSize, E = B + 2;
  const size_t vs = valueSize(mInfo.type);
  const size_t brickBytes = static_cast<size_t>(E * E * E) * vs;
  tbb::parallel_for(int64_t{0}, nb.x * nb.y, [&](int64_t b) {
    thread_local std::vector<char> brick;
    brick.resize(brickBytes);
    const int64_t bi = b % nb.x, bj = b / nb.x;
    const BrickRecord& rec = mLevel.records[static_cast<size_t>(b + nb.x * nb.y * kz)];
    BrickKey key{mLevelIndex, static_cast<uint32_t>(bi), static_cast<uint32_t>(bj), static_cast<uint32_t>(kz)};
    mFile.read(rec, key, brick.data(), brickBytes, mInfo.background);
    const int64_t wx = std::min(B, n.x - bi * B), wy = std::min(B, n.y - bj * B), wz = std::min(B, n.z - kz * B);
    for (int64_t c = 0; c < wz; ++c)
      for (int64_t yb = 0; yb < wy; ++yb) {
        const char* src = brick.data() + static_cast<size_t>((1 + E * ((yb + 1) + E * (c + 1)))) * vs;
        char* dst = mSlab.data() + static_cast<size_t>(bi * B + n.x * ((bj * B + yb) + n.y * c)) * vs;
        std::memcpy(dst, src, static_cast<size_t>(wx) * vs);
      }
  });
  mSlabLoaded = kz;
}

void StoredLevelSource::readSlices(int64_t count, void* dst) {
  const Vec3i n = mLevel.dims;
  if (count < 0 || mNextZ + count > n.z)
    throw StoreError("StoredLevelSource: reading past the last slice of " + mInfo.description);
  const size_t sliceBytes = static_cast<size_t>(n.x * n.y) * valueSize(mInfo.type);
  char* out = static_cast<char*>(dst);
  const int64_t z0 = mNextZ;
  for (int64_t s = 0; s < count; ++s, ++mNextZ) {
    int64_t kz = mNextZ / mBrickSize;
    if (kz != mSlabLoaded) loadSlab(kz);
    std::memcpy(out + static_cast<size_t>(s) * sliceBytes,
                mSlab.data() + static_cast<size_t>(mNextZ - kz * mBrickSize) * sliceBytes, sliceBytes);
  }
  if (mHook) mHook(z0, count, dst);
}

const void* StoredLevelSource::nextSlicesInPlace(int64_t count) {
  const int64_t kz = mNextZ / mBrickSize;
  if (count <= 0 || mNextZ + count > mLevel.dims.z || (mNextZ + count - 1) / mBrickSize != kz) return nullptr;
  if (kz != mSlabLoaded) loadSlab(kz);
  const size_t sliceBytes = static_cast<size_t>(mLevel.dims.x * mLevel.dims.y) * valueSize(mInfo.type);
  const char* first = mSlab.data() + static_cast<size_t>(mNextZ - kz * mBrickSize) * sliceBytes;
  if (mHook) mHook(mNextZ, count, first);
  mNextZ += count;
  return first;
}

DownsampleSource::DownsampleSource(VolumeSource& fine) : mFine(fine), mStored(dynamic_cast<StoredLevelSource*>(&fine)) {
  const VolumeInfo& f = fine.info();
  mInfo = f;
  mInfo.dims = {divUp(f.dims.x, 2), divUp(f.dims.y, 2), divUp(f.dims.z, 2)};
  mInfo.spacing = {f.spacing.x * 2, f.spacing.y * 2, f.spacing.z * 2};
  mInfo.description = "downsample of " + f.description;
  mPair.resize(static_cast<size_t>(2 * f.dims.x * f.dims.y) * valueSize(f.type));
}

void DownsampleSource::readSlices(int64_t count, void* dst) {
  dispatchType(mInfo.type, [&](auto tag) { readTyped(count, static_cast<decltype(tag)*>(dst)); });
}

template <typename T>
void DownsampleSource::readTyped(int64_t count, T* dst) {
  const Vec3i f = mFine.info().dims, n = mInfo.dims;
  if (count < 0 || mNextZ + count > n.z) throw StoreError("DownsampleSource: reading past the last slice");
  const int64_t sliceValues = f.x * f.y;
  T* pair = reinterpret_cast<T*>(mPair.data());
  for (int64_t s = 0; s < count; ++s, ++mNextZ) {
    const bool two = 2 * mNextZ + 1 < f.z;
    // The finer pair read where it lies when the finer level is stored (a pair never straddles two slabs of an even
    // brick size), else copied.
    const T* p0 = mStored ? static_cast<const T*>(mStored->nextSlicesInPlace(two ? 2 : 1)) : nullptr;
    if (!p0) {
      mFine.readSlices(two ? 2 : 1, pair);
      p0 = pair;
    }
    const T* p1 = two ? p0 + sliceValues : p0;
    T* out = dst + s * n.x * n.y;
    tbb::parallel_for(int64_t{0}, n.y, [&](int64_t y) {
      const int64_t y0 = 2 * y, y1 = std::min(2 * y + 1, f.y - 1);
      for (int64_t x = 0; x < n.x; ++x) {
        const int64_t x0 = 2 * x, x1 = std::min(2 * x + 1, f.x - 1);
        out[x + n.x * y] = downsampleVoxel(p0, p1, f.x, x0, x1, y0, y1);
      }
    });
  }
}

namespace {

/// A level stored as raw slices in host order (Level1Spill's scratch file), read in z order.
class SpilledLevelSource final : public VolumeSource {
 public:
  SpilledLevelSource(VolumeInfo info, const std::filesystem::path& path)
      : mInfo(std::move(info)), mStream(path.string(), 0, ByteStream::Compression::None) {}
  const VolumeInfo& info() const override { return mInfo; }
  void readSlices(int64_t count, void* dst) override {
    mStream.readExact(dst, static_cast<size_t>(count * mInfo.dims.x * mInfo.dims.y) * valueSize(mInfo.type));
  }

 private:
  VolumeInfo mInfo;
  ByteStream mStream;
};

}  // namespace

Level1Spill::Level1Spill(const VolumeInfo& fine, std::filesystem::path path)
    : mFine(fine), mPath(std::move(path)), mFile(mPath, throwIoError) {
  mCoarse = fine;
  mCoarse.dims = {divUp(fine.dims.x, 2), divUp(fine.dims.y, 2), divUp(fine.dims.z, 2)};
  mCoarse.spacing = {fine.spacing.x * 2, fine.spacing.y * 2, fine.spacing.z * 2};
  mCoarse.description = "level 1 of the store being written";
  mSlice.resize(static_cast<size_t>(mCoarse.dims.x * mCoarse.dims.y) * valueSize(fine.type));
}

void Level1Spill::addSlices(int64_t z0, int64_t count, const void* values) {
  if (z0 != mNextZ || z0 % 2 != 0 || (count % 2 != 0 && z0 + count != mFine.dims.z))
    throw StoreError("Level1Spill: slices " + std::to_string(z0) + "+" + std::to_string(count) + " out of order");
  dispatchType(mFine.type, [&](auto tag) { addTyped(z0, count, static_cast<const decltype(tag)*>(values)); });
  mNextZ += count;
}

template <typename T>
void Level1Spill::addTyped(int64_t z0, int64_t count, const T* values) {
  const Vec3i f = mFine.dims, n = mCoarse.dims;
  const int64_t sliceValues = f.x * f.y;
  T* out = reinterpret_cast<T*>(mSlice.data());
  for (int64_t s = 0; s < count; s += 2) {
    const T* p0 = values + s * sliceValues;
    const T* p1 = z0 + s + 1 < f.z ? p0 + sliceValues : p0;
    tbb::parallel_for(int64_t{0}, n.y, [&](int64_t y) {
      const int64_t y0 = 2 * y, y1 = std::min(2 * y + 1, f.y - 1);
      for (int64_t x = 0; x < n.x; ++x) {
        const int64_t x0 = 2 * x, x1 = std::min(2 * x + 1, f.x - 1);
        out[x + n.x * y] = downsampleVoxel(p0, p1, f.x, x0, x1, y0, y1);
      }
    });
    mFile.append(mSlice.data(), mSlice.size());
  }
}

std::unique_ptr<VolumeSource> Level1Spill::spilled() const {
  if (mNextZ != mFine.dims.z) throw StoreError("Level1Spill: level 0 not complete");
  return std::make_unique<SpilledLevelSource>(mCoarse, mPath);
}

}  // namespace voxbrick::store
