// The canonical OpenVDB float grid of level 0, written in z-chunks so that memory stays bounded.
#pragma once

#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "brickstore/prep/PhaseClock.h"
#include "brickstore/source/VolumeSource.h"
#include "common/EnumNames.h"

namespace voxbrick::store {

/// How the VDB files store their leaf values (inactive values are left out whichever).
enum class VdbCompression {
  Auto,   ///< blosc for a chunk whose sampled leaves it shrinks to half or less, else none
  Blosc,  ///< blosc (LZ4), OpenVDB's default
  None,   ///< as they are
};

/// --vdb-compression's names.
inline constexpr common::EnumName<VdbCompression> kVdbCompressionNames[] = {
    {VdbCompression::Auto, "auto"}, {VdbCompression::Blosc, "blosc"}, {VdbCompression::None, "none"}};
constexpr std::span<const common::EnumName<VdbCompression>> enumNames(VdbCompression) { return kVdbCompressionNames; }

/// Receives level-0 slices in z order and writes them as OpenVDB FloatGrids named "density", one file per chunk of
/// `chunkSlices` slices (vdb/level0-zNNNNN.vdb, NNNNN the chunk's first z). Voxels equal to the background are
/// inactive. Index (i, j, k) of every chunk is voxel (i, j, k) of the volume; the transform places voxel centres
/// as the optical model does ((i + 1/2 - n/2) * spacing), so the chunks together form one grid. Each file is what
/// openvdb::io::File writes for the chunk's tree, made without the tree (VdbLeafChunk); a complete chunk is written
/// on a thread of its own while the next one is cut.
/// Level 0 written as OpenVDB grids, chunk by chunk (brickstore/modules/openvdb/VdbChunkFiles.cpp): each chunk's
/// leaves cut as its slices arrive, its file written on a thread of its own while the next chunk is cut. Made by the
/// OpenVDB module, loaded the first time one is made or sized (common::ModuleError if it cannot be).
class VdbChunkWriter {
 public:
  /// A writer of the grid of a volume `info` into storeDir/vdb, in chunks of chunkSlices slices.
  static std::unique_ptr<VdbChunkWriter> make(const std::filesystem::path& storeDir, const VolumeInfo& info,
                                              double background, int64_t chunkSlices,
                                              VdbCompression compression = VdbCompression::Auto);
  virtual ~VdbChunkWriter() = default;

  /// Adds `count` slices starting at z0 (the next ones in order) of the volume's type.
  virtual void addSlices(int64_t z0, int64_t count, const void* values) = 0;
  /// Once every slice is in: the last chunk's file goes on being written while the caller does other work, and the
  /// memory that no chunk needs any more is freed. Throws std::logic_error if slices are missing.
  virtual void finish() = 0;
  /// Waits for every file. Throws IoError if a file could not be written (also from addSlices, for an earlier
  /// chunk's file). files() and bytes() are complete after it.
  virtual void wait() = 0;

  /// Files written, relative to the store directory.
  virtual const std::vector<std::string>& files() const = 0;
  virtual int64_t bytes() const = 0;
  /// Time the slices waited for chunk files to be written (a chunk complete before the previous file was, and the
  /// last file), summed: the writing not hidden behind the next chunk's work.
  virtual const PhaseTime& writeTime() const = 0;

  /// Bytes a chunk of `slices` slices is planned for: what sizes the chunks (and so the files), fixed so that the
  /// same options give the same files: its kept leaves at most, twice (one chunk cut while the one before is
  /// written).
  static int64_t chunkBytes(const Vec3i& dims, int64_t slices);
  /// Bytes the writer holds at most with chunks of `slices` slices: chunkBytes and its headers and topology.
  static int64_t residentBytes(const Vec3i& dims, int64_t slices);
};

/// The OpenVDB module's prep side: the table its entry VOXBRICK_VDB_PREP_ENTRY gives (common/Modules.h; the name
/// changes with the table).
struct VdbPrepModule {
  std::unique_ptr<VdbChunkWriter> (*make)(const std::filesystem::path& storeDir, const VolumeInfo& info,
                                          double background, int64_t chunkSlices, VdbCompression compression);
  int64_t (*chunkBytes)(const Vec3i& dims, int64_t slices);
  int64_t (*residentBytes)(const Vec3i& dims, int64_t slices);
};
#define VOXBRICK_VDB_PREP_ENTRY voxbrick_module_openvdb_prep_v1

}  // namespace voxbrick::store
