// prep's source for an OME-Zarr: a pyramid level read in z order from its chunks, and the Zarr's own coarser levels
// offered to prep (VolumeSource::ownLevel) exactly where the live store (ZarrStore) uses them.
#include <algorithm>
#include <memory>

#include "brickstore/format/Errors.h"
#include "brickstore/format/InputErrors.h"
#include "brickstore/ingest/zarr/ZarrSource.h"
#include "brickstore/zarr/ZarrChunks.h"

namespace voxbrick::store {
namespace {

/// Decoded chunks kept while streaming: one row of chunks across a slab (each chunk then decodes once), at least
/// 64 MiB.
size_t streamingCacheBytes(const ZarrArrayMeta& a) {
  return size_t(std::max<int64_t>(int64_t{64} << 20, a.chunkGrid.x * a.chunkGrid.y * a.chunkBytes()));
}

class ZarrSource final : public VolumeSource {
 public:
  ZarrSource(std::shared_ptr<const ZarrChunks> chunks, int level, std::vector<bool> own)
      : mChunks(std::move(chunks)), mLevel(level), mOwn(std::move(own)) {
    const ZarrMeta& m = mChunks->meta();
    const ZarrArrayMeta& a = m.levels[size_t(level)];
    mInfo.dims = a.dims;
    mInfo.spacing = a.scale;
    mInfo.type = mChunks->type();
    mInfo.background = mChunks->background();
    mInfo.description = m.description() + (level ? ", level " + a.path : std::string());
    mInfo.orientation.origin = a.translation;
  }

  const VolumeInfo& info() const override { return mInfo; }

  void readSlices(int64_t count, void* dst) override {
    if (count <= 0) return;
    if (mNextZ + count > mInfo.dims.z) throw InputError(mChunks->meta().root.string() + ": read past the last z-slice");
    const Vec3i lo{0, 0, mNextZ}, hi{mInfo.dims.x - 1, mInfo.dims.y - 1, mNextZ + count - 1};
    namingInput({mChunks->meta().root.string()}, [&] { mChunks->readRegion(mLevel, lo, hi, dst); });
    mNextZ += count;
  }

  std::unique_ptr<VolumeSource> ownLevel(int level, const Vec3i& dims) override {
    if (mLevel != 0 || level <= 0 || size_t(level) >= mOwn.size() || !mOwn[size_t(level)]) return nullptr;
    if (!(mChunks->meta().levels[size_t(level)].dims == dims)) return nullptr;
    return std::make_unique<ZarrSource>(mChunks, level, mOwn);
  }

 private:
  std::shared_ptr<const ZarrChunks> mChunks;
  int mLevel;
  std::vector<bool> mOwn;
  VolumeInfo mInfo;
  int64_t mNextZ = 0;
};

}  // namespace

std::unique_ptr<VolumeSource> openZarrSource(const std::string& dir, const SourceOptions& options) {
  if (options.spacingGiven)
    throw InputError(dir + ": --spacing does not apply to an OME-Zarr (its coordinateTransformations give it)");
  ZarrMeta meta = readZarrMeta(dir, {options.time, options.channel});
  const size_t cache = streamingCacheBytes(meta.levels.front());
  auto chunks = std::make_shared<const ZarrChunks>(std::move(meta), cache);
  // Prep's pyramid uses the brick size it is given; ownLevel checks the dims it asks for, so the brick size used
  // here only bounds which levels are offered (any B gives the same halving chain up to its last level).
  std::vector<bool> own = zarrOwnLevels(chunks->meta(), 8);
  return std::make_unique<ZarrSource>(std::move(chunks), 0, std::move(own));
}

}  // namespace voxbrick::store
