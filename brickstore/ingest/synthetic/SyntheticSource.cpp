// The "synthetic:" ingest source: an analytic field sampled at cell centres, one batch of z-slices at a time.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "brickstore/format/Errors.h"
#include "brickstore/ingest/synthetic/SyntheticField.h"
#include "brickstore/ingest/synthetic/SyntheticSource.h"

namespace voxbrick::store {
namespace {

class SyntheticSource final : public VolumeSource {
 public:
  explicit SyntheticSource(SyntheticField field) : mField(std::move(field)) {
    mInfo.dims = mField.dims();
    mInfo.spacing = mField.spacing();
    mInfo.type = mField.type();
    mInfo.background = mField.background();
    mInfo.description = "synthetic " + mField.name() + " " + std::to_string(mInfo.dims.x) + "x" +
                        std::to_string(mInfo.dims.y) + "x" + std::to_string(mInfo.dims.z);
  }

  const VolumeInfo& info() const override { return mInfo; }
  const SyntheticField* analytic() const override { return &mField; }

  void readSlices(int64_t count, void* dst) override {
    const Vec3i& n = mInfo.dims;
    if (count < 0 || count > n.z - mNextZ)
      throw InputError(mInfo.description + ": asked for " + std::to_string(count) +
                       " slices at z = " + std::to_string(mNextZ) + ", but the volume has " + std::to_string(n.z));
    float* out = static_cast<float*>(dst);
    const int64_t z0 = mNextZ;
    // One task per row keeps the grain coarse enough for tbb yet fine enough to balance a single slice.
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, count * n.y), [&](const tbb::blocked_range<int64_t>& rows) {
      for (int64_t row = rows.begin(); row != rows.end(); ++row) {
        mField.sampleRow(row % n.y, z0 + row / n.y, out + row * n.x);
      }
    });
    mNextZ += count;
  }

 private:
  SyntheticField mField;
  VolumeInfo mInfo;
  int64_t mNextZ = 0;
};

}  // namespace

std::unique_ptr<VolumeSource> openSyntheticSource(const std::string& spec, const SourceOptions& options) {
  SyntheticField field = SyntheticField::parse(spec);
  if (options.spacingGiven) field.setSpacing(options.spacing);
  return std::make_unique<SyntheticSource>(std::move(field));
}

}  // namespace voxbrick::store
