// The canonical OpenVDB float grid of level 0, written in z-chunks so that memory stays bounded.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "brickstore/PhaseClock.h"
#include "brickstore/VolumeSource.h"

namespace voxbrick::store {

/// How the VDB files store their leaf values (inactive values are left out whichever).
enum class VdbCompression {
  Auto,   ///< blosc for a chunk whose sampled leaves it shrinks to half or less, else none
  Blosc,  ///< blosc (LZ4), OpenVDB's default
  None,   ///< as they are
};

/// Receives level-0 slices in z order and writes them as OpenVDB FloatGrids named "density", one file per chunk of
/// `chunkSlices` slices (vdb/level0-zNNNNN.vdb, NNNNN the chunk's first z). Voxels equal to the background are
/// inactive. Index (i, j, k) of every chunk is voxel (i, j, k) of the volume; the transform places voxel centres
/// as the optical model does ((i + 1/2 - n/2) * spacing), so the chunks together form one grid.
class VdbChunkWriter {
 public:
  VdbChunkWriter(const std::filesystem::path& storeDir, const VolumeInfo& info, double background, int64_t chunkSlices,
                 VdbCompression compression = VdbCompression::Auto);
  ~VdbChunkWriter();

  /// Adds `count` slices starting at z0 (the next ones in order) of the volume's type.
  void addSlices(int64_t z0, int64_t count, const void* values);
  /// Writes the last partial chunk. Throws IoError if a file cannot be written.
  void finish();

  /// Files written, relative to the store directory.
  const std::vector<std::string>& files() const { return mFiles; }
  int64_t bytes() const { return mBytes; }
  /// Time spent writing chunk files (building a chunk's grid is not counted), summed over the chunks.
  const PhaseTime& writeTime() const { return mWriteTime; }

  /// Bytes of grid memory a chunk of `slices` slices is planned for: what sizes the chunks (and so the files), fixed
  /// so that the same options give the same files.
  static int64_t chunkBytes(const Vec3i& dims, int64_t slices);
  /// Bytes a chunk of `slices` slices holds at most: dense float leaves and the batches of compressed leaves in
  /// flight while it is written. Less than chunkBytes; the difference goes to slabs read ahead.
  static int64_t residentBytes(const Vec3i& dims, int64_t slices);

 private:
  struct Impl;
  void flush();

  std::filesystem::path mDir;
  VolumeInfo mInfo;
  double mBackground;
  int64_t mChunkSlices;
  VdbCompression mCompression;
  int64_t mChunkStart = 0;
  std::unique_ptr<Impl> mImpl;
  std::vector<std::string> mFiles;
  int64_t mBytes = 0;
  PhaseTime mWriteTime{"grid files written", 0, 0};
};

}  // namespace voxbrick::store
