// Writing level 0 as OpenVDB grids, chunk by chunk.
#include "brickstore/VdbChunkWriter.h"

#include <openvdb/openvdb.h>

#include <cstdio>

#include "brickstore/Errors.h"
#include "brickstore/OpenVdbInit.h"
#include "brickstore/VdbParallelWrite.h"
#include "brickstore/VdbSlices.h"

namespace voxbrick::store {

struct VdbChunkWriter::Impl {
  ParallelWriteFloatGrid::Ptr grid;
};

int64_t VdbChunkWriter::chunkBytes(const Vec3i& dims, int64_t slices) {
  // A dense float leaf holds 512 values in 2 KiB plus its mask and node overhead (about 4.2 bytes a voxel), and
  // writing it compresses leaf buffers into temporary copies: 8 bytes a voxel matches the peak resident size
  // measured by bench/run_memory_bound.sh.
  return dims.x * dims.y * slices * 8;
}

int64_t VdbChunkWriter::residentBytes(const Vec3i& dims, int64_t slices) {
  // A leaf is 2 KiB of values, a 64-byte mask, its origin and the allocator's header (4.2 bytes a voxel), but peak
  // RSS says more: 4.4 bytes a voxel on 512^3 (one chunk of 416 slices), 6.4 on 1024^3 (chunks of 64 slices, freed
  // and allocated again); writing holds a few batches of compressed leaves (writeLeafBuffersParallel), a few MB.
  return dims.x * dims.y * slices * 13 / 2 + (int64_t{16} << 20);
}

VdbChunkWriter::VdbChunkWriter(const std::filesystem::path& storeDir, const VolumeInfo& info, double background,
                               int64_t chunkSlices, VdbCompression compression)
    : mDir(storeDir),
      mInfo(info),
      mBackground(background),
      mChunkSlices(chunkSlices),
      mCompression(compression),
      mImpl(new Impl) {
  initializeOpenVdb();
  std::error_code ec;
  std::filesystem::create_directories(mDir / "vdb", ec);
  if (ec) throw IoError("cannot create " + (mDir / "vdb").string() + ": " + ec.message());
}

VdbChunkWriter::~VdbChunkWriter() = default;

void VdbChunkWriter::addSlices(int64_t z0, int64_t count, const void* values) {
  const Vec3i n = mInfo.dims;
  const size_t sliceBytes = static_cast<size_t>(n.x * n.y) * valueSize(mInfo.type);
  const char* bytes = static_cast<const char*>(values);
  while (count > 0) {
    if (z0 >= mChunkStart + mChunkSlices) {
      flush();
      mChunkStart += mChunkSlices;
    }
    const int64_t take = std::min(count, mChunkStart + mChunkSlices - z0);
    if (!mImpl->grid) mImpl->grid = std::make_shared<ParallelWriteFloatGrid>(static_cast<float>(mBackground));
    dispatchType(mInfo.type, [&](auto tag) {
      using T = decltype(tag);
      addSlicesToTree(mImpl->grid->tree(), reinterpret_cast<const T*>(bytes), n, z0, take);
    });
    bytes += static_cast<size_t>(take) * sliceBytes;
    z0 += take;
    count -= take;
  }
}

void VdbChunkWriter::flush() {
  if (!mImpl->grid) return;
  const PhaseClock clock;
  ParallelWriteFloatGrid::Ptr grid = std::move(mImpl->grid);
  mImpl->grid.reset();
  const Vec3i n = mInfo.dims;
  const Vec3d s = mInfo.spacing;
  openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
  m.preScale(openvdb::Vec3d(s.x, s.y, s.z));
  m.postTranslate(openvdb::Vec3d((0.5 - 0.5 * double(n.x)) * s.x, (0.5 - 0.5 * double(n.y)) * s.y,
                                 (0.5 - 0.5 * double(n.z)) * s.z));
  grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
  grid->setName("density");
  grid->setGridClass(openvdb::GRID_FOG_VOLUME);
  grid->insertMeta("voxbrick_dims", openvdb::Vec3IMetadata(openvdb::Vec3i(int(n.x), int(n.y), int(n.z))));
  grid->insertMeta("voxbrick_chunk_z0", openvdb::Int64Metadata(mChunkStart));

  char name[64];
  std::snprintf(name, sizeof name, "vdb/level0-z%05lld.vdb", static_cast<long long>(mChunkStart));
  const std::filesystem::path path = mDir / name;
  try {
    openvdb::io::File file(path.string());
    // Blosc costs about 3 ns of CPU a byte of leaf values (a fifth of prep's CPU on noisy float data, where it saves
    // 15 %); under Auto it is used where it at least halves the bytes written.
    const bool blosc = mCompression == VdbCompression::Blosc ||
                       (mCompression == VdbCompression::Auto && bloscShrinksTo(grid->tree(), 0.5));
    if (!blosc) file.setCompression(openvdb::io::COMPRESS_ACTIVE_MASK);
    file.write({grid});
    file.close();
  } catch (const std::exception& e) {
    throw IoError("cannot write " + path.string() + ": " + e.what());
  }
  std::error_code ec;
  auto size = std::filesystem::file_size(path, ec);
  if (ec) throw IoError("cannot write " + path.string() + ": " + ec.message());
  mBytes += static_cast<int64_t>(size);
  mFiles.push_back(name);
  // Freed here, so that the time is counted (Tree::clear frees the nodes on every thread).
  grid->tree().clear();
  const PhaseTime t = clock.elapsed("");
  mWriteTime.wallSeconds += t.wallSeconds;
  mWriteTime.cpuSeconds += t.cpuSeconds;
}

void VdbChunkWriter::finish() { flush(); }

}  // namespace voxbrick::store
