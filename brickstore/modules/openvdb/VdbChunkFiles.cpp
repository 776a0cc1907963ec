// Writing level 0 as OpenVDB grids, chunk by chunk (the OpenVDB module's VdbChunkWriter): each chunk's leaves cut as
// its slices arrive, its file written on a thread of its own while the next chunk is cut.
#include "brickstore/modules/openvdb/OpenVdbModule.h"

#include <openvdb/openvdb.h>

#include <cstdio>
#include <future>

#include "brickstore/format/Errors.h"
#include "brickstore/vdb/OpenVdbInit.h"
#include "brickstore/vdb/VdbLeafChunk.h"

namespace voxbrick::store {
namespace {

class VdbChunkFiles final : public VdbChunkWriter {
 public:
  VdbChunkFiles(const std::filesystem::path& storeDir, const VolumeInfo& info, double background, int64_t chunkSlices,
                VdbCompression compression);
  ~VdbChunkFiles() override;

  void addSlices(int64_t z0, int64_t count, const void* values) override;
  void finish() override;
  void wait() override;
  const std::vector<std::string>& files() const override { return mFiles; }
  int64_t bytes() const override { return mBytes; }
  const PhaseTime& writeTime() const override { return mWriteTime; }

 private:
  struct Impl {
    Impl(const Vec3i& dims, float background) : chunks{{dims, background}, {dims, background}} {}
    VdbLeafChunk chunks[2];
    int filling = 0;            ///< the chunk receiving slices
    bool started = false;       ///< whether it has begun
    std::future<void> writing;  ///< the other chunk's file
    std::string writingName;
    int64_t writtenBytes = 0;
  };

  void handOff();
  void collect();

  std::filesystem::path mDir;
  VolumeInfo mInfo;
  double mBackground;
  int64_t mChunkSlices;
  VdbCompression mCompression;
  int64_t mChunkStart = 0;
  std::unique_ptr<Impl> mImpl;
  std::vector<std::string> mFiles;
  int64_t mBytes = 0;
  PhaseTime mWriteTime{"grid files: waiting for the writer", 0, 0};
};

VdbChunkFiles::VdbChunkFiles(const std::filesystem::path& storeDir, const VolumeInfo& info, double background,
                             int64_t chunkSlices, VdbCompression compression)
    : mDir(storeDir),
      mInfo(info),
      mBackground(background),
      mChunkSlices(chunkSlices),
      mCompression(compression),
      mImpl(new Impl(info.dims, static_cast<float>(background))) {
  initializeOpenVdb();
  std::error_code ec;
  std::filesystem::create_directories(mDir / "vdb", ec);
  if (ec) throw IoError("cannot create " + (mDir / "vdb").string() + ": " + ec.message());
}

VdbChunkFiles::~VdbChunkFiles() {
  if (mImpl->writing.valid()) mImpl->writing.wait();  // an error already thrown elsewhere, or the prep abandoned
}

void VdbChunkFiles::addSlices(int64_t z0, int64_t count, const void* values) {
  const Vec3i n = mInfo.dims;
  const size_t sliceBytes = static_cast<size_t>(n.x * n.y) * valueSize(mInfo.type);
  const char* bytes = static_cast<const char*>(values);
  while (count > 0) {
    VdbLeafChunk& chunk = mImpl->chunks[mImpl->filling];
    if (!mImpl->started) {
      chunk.begin(mChunkStart, std::min(mChunkStart + mChunkSlices, n.z));
      mImpl->started = true;
    }
    const int64_t take = std::min(count, mChunkStart + mChunkSlices - z0);
    dispatchType(mInfo.type, [&](auto tag) {
      using T = decltype(tag);
      chunk.addSlices(reinterpret_cast<const T*>(bytes), z0, take);
    });
    bytes += static_cast<size_t>(take) * sliceBytes;
    z0 += take;
    count -= take;
    if (chunk.complete()) handOff();
  }
}

void VdbChunkFiles::collect() {
  if (!mImpl->writing.valid()) return;
  const PhaseClock clock;
  std::future<void> writing = std::move(mImpl->writing);
  writing.get();  // rethrows the writer's IoError
  mBytes += mImpl->writtenBytes;
  mFiles.push_back(mImpl->writingName);
  const PhaseTime t = clock.elapsed("");
  mWriteTime.wallSeconds += t.wallSeconds;
  mWriteTime.cpuSeconds += t.cpuSeconds;
}

void VdbChunkFiles::handOff() {
  collect();  // the chunk before this one: its file is written, and its memory free for the next chunk
  VdbLeafChunk& chunk = mImpl->chunks[mImpl->filling];
  const Vec3i n = mInfo.dims;
  const Vec3d s = mInfo.spacing;
  auto grid = openvdb::FloatGrid::create(static_cast<float>(mBackground));
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
  mImpl->writingName = name;
  const std::filesystem::path path = mDir / name;
  const VdbCompression compression = mCompression;
  mImpl->writing = std::async(std::launch::async, [this, &chunk, grid, path, compression] {
    // Blosc costs about 3 ns of CPU a byte of leaf values (a fifth of prep's CPU on noisy float data, where it
    // saves 15 %); under Auto it is used where it at least halves the bytes written.
    const bool blosc =
        compression == VdbCompression::Blosc || (compression == VdbCompression::Auto && chunk.bloscShrinksTo(0.5));
    mImpl->writtenBytes = chunk.write(path, *grid, blosc);
  });
  mImpl->filling = 1 - mImpl->filling;
  mImpl->started = false;
  mChunkStart += mChunkSlices;
}

void VdbChunkFiles::finish() {
  if (mImpl->started) throw std::logic_error("VdbChunkWriter: the volume's last slices are missing");
  mImpl->chunks[mImpl->filling].release();  // the chunk being written is the other one
}

void VdbChunkFiles::wait() { collect(); }

}  // namespace

std::unique_ptr<VdbChunkWriter> makeVdbChunkFiles(const std::filesystem::path& storeDir, const VolumeInfo& info,
                                                  double background, int64_t chunkSlices, VdbCompression compression) {
  return std::make_unique<VdbChunkFiles>(storeDir, info, background, chunkSlices, compression);
}

int64_t vdbChunkBytes(const Vec3i& dims, int64_t slices) { return 2 * VdbLeafChunk::maxBytes(dims, slices); }

int64_t vdbResidentBytes(const Vec3i& dims, int64_t slices) {
  // The topology a file is written with (a leaf's 64-byte mask of its 2 KiB of values, the nodes above it, the
  // delayed-load record), the 2 MB it is written through, and a few more.
  return vdbChunkBytes(dims, slices) + vdbChunkBytes(dims, slices) / 32 + (int64_t{4} << 20);
}

}  // namespace voxbrick::store
