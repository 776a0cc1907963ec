// The metadata of an OME-Zarr volume (OME-NGFF 0.4 multiscales over Zarr v2): the group's .zattrs, each pyramid
// level's .zarray, the axes, the chosen time point and channel, spacing and position. Everything is checked here,
// before any chunk is read or any buffer is sized from it; docs/zarr.md says what is read and what is refused.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "brickstore/format/Orientation.h"
#include "brickstore/format/Types.h"
#include "common/EnumNames.h"

namespace voxbrick::store {

enum class FileValueType : uint8_t;  // brickstore/format/Convert.h

/// Which 3D volume of a 4D/5D OME-Zarr to read (--time, --channel): indices along its t and c axes.
struct ZarrSelection {
  int64_t time = 0;
  int64_t channel = 0;
};

/// How a chunk file is compressed (the .zarray's "compressor").
enum class ZarrCompressor { None, Zlib, Gzip, Zstd, Blosc };

/// The compressor ids a .zarray may name ("compressor": null is None, which has no id).
inline constexpr common::EnumName<ZarrCompressor> kZarrCompressorNames[] = {{ZarrCompressor::Zlib, "zlib"},
                                                                            {ZarrCompressor::Gzip, "gzip"},
                                                                            {ZarrCompressor::Zstd, "zstd"},
                                                                            {ZarrCompressor::Blosc, "blosc"}};
constexpr std::span<const common::EnumName<ZarrCompressor>> enumNames(ZarrCompressor) { return kZarrCompressorNames; }

/// One array of the pyramid (a multiscales dataset), as its .zarray declares it.
struct ZarrArrayMeta {
  std::filesystem::path dir;    ///< the array's directory
  std::string path;             ///< the dataset's "path" in the group ("0", "1", ...)
  std::vector<int64_t> shape;   ///< per axis, in the file's axis order (t, c, z, y, x or a suffix of it)
  std::vector<int64_t> chunks;  ///< chunk shape per axis
  FileValueType fileType{};     ///< "dtype" (Convert.h)
  bool bigEndian = false;
  bool fortranOrder = false;  ///< "order": "F"
  char separator = '.';       ///< "dimension_separator"
  ZarrCompressor compressor = ZarrCompressor::None;
  std::string compressorText;                  ///< e.g. "blosc lz4 shuffle", for descriptions
  double fillValue = 0;                        ///< "fill_value" as a number (null: 0)
  Vec3i dims;                                  ///< the spatial shape: x, y, z
  Vec3i chunkDims;                             ///< the spatial chunk shape: x, y, z
  Vec3i chunkGrid;                             ///< chunks along x, y, z
  Vec3d scale{1, 1, 1};                        ///< coordinateTransformations: the voxel size along x, y, z
  std::array<double, 3> translation{0, 0, 0};  ///< coordinateTransformations: the position of voxel 0 (x, y, z)

  /// Bytes of one decoded chunk.
  int64_t chunkBytes() const;
  /// The file of spatial chunk (cx, cy, cz) at the selection's time and channel.
  std::filesystem::path chunkFile(const Vec3i& chunk, const std::vector<int64_t>& fixedChunkIndex) const;
};

/// A whole OME-Zarr multiscales image with one (t, c) chosen.
struct ZarrMeta {
  std::filesystem::path root;           ///< the group directory
  std::vector<std::string> axisNames;   ///< e.g. {"t", "c", "z", "y", "x"}
  int timeAxis = -1, channelAxis = -1;  ///< index into the axes, or -1
  ZarrSelection selection;
  std::vector<ZarrArrayMeta> levels;  ///< the multiscales datasets, finest first
  std::string unit;                   ///< the spatial axes' unit, if given
  std::string version;                ///< the multiscales "version" ("0.4", ...)

  /// The store type the levels are read as (u8, u16, i16 as themselves; int8 as i16; the rest f32).
  ValueType storeType() const;
  /// The background: level 0's fill value in the store type.
  double background() const;
  /// Per axis of the file, the chunk index of the chosen time and channel (0 for spatial axes).
  std::vector<int64_t> fixedChunkIndex() const;
  /// Per axis, the position inside a chunk of the chosen time and channel (0 for spatial axes).
  std::vector<int64_t> fixedInChunk() const;
  /// "OME-Zarr 0.4 uint16 blosc lz4 shuffle 256x256x128, 4 levels (t=0 c=1)" for descriptions.
  std::string description() const;
};

/// True if `dir` is a directory holding a Zarr v2 group with OME multiscales metadata (a .zattrs naming
/// "multiscales"), or a Zarr v3 group (zarr.json, which ZarrMeta::read refuses by name): what the dataset openers
/// treat as an OME-Zarr.
bool isZarrDirectory(const std::filesystem::path& dir);

/// Reads and checks the metadata of the OME-Zarr at `root` with `selection`. Throws InputError naming the file and
/// the field: Zarr v3 (zarr.json), a missing or malformed .zattrs/.zarray, unknown compressors and filters, dtypes
/// that are not scalar numbers (or 64-bit integers), shapes and chunks beyond the limits, shapes that disagree
/// between levels or with the axes, levels that do not shrink, a time or channel outside its axis.
ZarrMeta readZarrMeta(const std::filesystem::path& root, const ZarrSelection& selection);

/// Which store levels (of pyramidDims(level-0 dims, B)) are the Zarr's own datasets: level m is dataset m when
/// dataset m's spatial shape is exactly level m's dims (each axis halved, rounding up) and level m - 1 is the Zarr's
/// own too; every other level is the 2x2x2 average of the level below, as prep builds it. Level 0 is always own.
std::vector<bool> zarrOwnLevels(const ZarrMeta& meta, int brickSize);

/// The largest decoded chunk accepted (bytes) and the most chunks along the spatial grid of one level.
inline constexpr int64_t kMaxZarrChunkBytes = int64_t{1} << 30;
inline constexpr int64_t kMaxZarrChunksPerLevel = int64_t{1} << 24;

}  // namespace voxbrick::store
