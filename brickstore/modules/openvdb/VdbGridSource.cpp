// The OpenVDB module's ingest source: one float grid of a .vdb file, read densely over its active voxels' bounding
// box.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>

#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "brickstore/format/Errors.h"
#include "brickstore/modules/openvdb/OpenVdbModule.h"
#include "brickstore/vdb/VdbGrid.h"

namespace voxbrick::store {
namespace {

using DenseSlab = openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ>;  // x fastest, as readSlices delivers

class VdbSource final : public VolumeSource {
 public:
  VdbSource(std::string path, VdbFloatGrid chosen)
      : mPath(std::move(path)), mGrid(std::move(chosen.grid)), mBBox(chosen.bbox) {
    mInfo.dims = chosen.dims;
    mInfo.spacing = chosen.spacing;
    mInfo.type = ValueType::F32;
    mInfo.background = mGrid->background();
    mInfo.description = std::move(chosen.description);
  }

  const VolumeInfo& info() const override { return mInfo; }

  void readSlices(int64_t count, void* dst) override {
    const Vec3i& n = mInfo.dims;
    if (count < 0 || count > n.z - mNextZ)
      throw InputError(mPath + ": asked for " + std::to_string(count) + " slices at z = " + std::to_string(mNextZ) +
                       ", but the active bounding box has " + std::to_string(n.z));
    if (count == 0) return;
    const openvdb::Coord lo = mBBox.min(), hi = mBBox.max();
    const int zMin = lo.z() + static_cast<int>(mNextZ), zMax = zMin + static_cast<int>(count) - 1;
    DenseSlab dense(openvdb::CoordBBox(lo.x(), lo.y(), zMin, hi.x(), hi.y(), zMax), static_cast<float*>(dst));
    openvdb::tools::CopyToDense<openvdb::FloatTree, DenseSlab> copy(mGrid->tree(), dense);
    // CopyToDense splits its box only while every side is > 1, so a one-slice slab would run on one thread;
    // split by hand into bands of y aligned to leaf nodes (8 voxels) instead. Inactive voxels copy their stored
    // value, which is the background almost everywhere.
    const int firstBand = lo.y() >> 3, lastBand = hi.y() >> 3;
    tbb::parallel_for(tbb::blocked_range<int>(firstBand, lastBand + 1), [&](const tbb::blocked_range<int>& bands) {
      for (int band = bands.begin(); band != bands.end(); ++band) {
        const int y0 = std::max(lo.y(), band * 8), y1 = std::min(hi.y(), band * 8 + 7);
        copy(openvdb::CoordBBox(lo.x(), y0, zMin, hi.x(), y1, zMax));
      }
    });
    mNextZ += count;
  }

 private:
  std::string mPath;
  openvdb::FloatGrid::Ptr mGrid;
  openvdb::CoordBBox mBBox;
  VolumeInfo mInfo;
  int64_t mNextZ = 0;
};

}  // namespace

std::unique_ptr<VolumeSource> openVdbGridSource(const std::string& path, const SourceOptions& options) {
  const std::optional<Vec3d> spacing = options.spacingGiven ? std::optional<Vec3d>(options.spacing) : std::nullopt;
  return std::make_unique<VdbSource>(path, readVdbFloatGrid(path, options.gridName, spacing));
}

}  // namespace voxbrick::store
