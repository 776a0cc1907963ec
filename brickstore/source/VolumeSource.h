// The one interface every ingest format implements and prep consumes: a volume read as a stream of z-slices.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "brickstore/format/Orientation.h"
#include "brickstore/format/Types.h"

namespace voxbrick::store {

class SyntheticField;

/// What a source knows about its volume before any voxel is read.
struct VolumeInfo {
  Vec3i dims;                       ///< voxels along x, y, z; all > 0
  Vec3d spacing;                    ///< physical voxel size; all > 0 and finite
  ValueType type = ValueType::F32;  ///< type of the slices readSlices() delivers
  double background = 0.0;          ///< value of empty space (a VDB grid's background; 0 for dense files)
  std::string description;          ///< one line for logs, e.g. "NRRD uint16 gzip 256x256x128"
  Orientation orientation;          ///< index-to-world (RAS); identity for inputs without a patient frame
};

/// A volume delivered in order, z-slice by z-slice, so that files larger than memory stream through a bounded
/// window and compressed files need no seeking.
class VolumeSource {
 public:
  virtual ~VolumeSource() = default;

  /// The volume's dimensions, spacing, type and background.
  virtual const VolumeInfo& info() const = 0;

  /// Reads the next `count` z-slices into dst: count * dims.x * dims.y values of info().type, x fastest, then y,
  /// then z, in host byte order. The first call starts at z = 0. Throws InputError (naming the file) when the
  /// data is truncated or malformed, or when reading past dims.z.
  virtual void readSlices(int64_t count, void* dst) = 0;

  /// A fresh source over the same data, from z = 0, when reading it again costs little more than copying the bytes
  /// (an uncompressed file): prep then counts a float histogram from it instead of reading its level 0 back. Null
  /// (the default) otherwise.
  virtual std::unique_ptr<VolumeSource> reopen() const { return nullptr; }

  /// The analytic definition of a synthetic source (so tests can compare with the true function); else null.
  virtual const SyntheticField* analytic() const { return nullptr; }

  /// The input's own pyramid level `level` (1 = the first coarser), read as a source of `dims` voxels, when the
  /// input holds one of exactly those dims (an OME-Zarr's multiscales); prep then stores it as that LOD level
  /// instead of averaging the level below. Null (the default): the level is averaged.
  virtual std::unique_ptr<VolumeSource> ownLevel(int level, const Vec3i& dims) {
    (void)level;
    (void)dims;
    return nullptr;
  }
};

/// How a DICOMweb input (dicomweb://, dicomwebs://) is fetched: docs/inputs.md#dicomweb.
struct DicomWebOptions {
  std::string caFile;    ///< PEM certificates trusted for HTTPS; "" for the system's store
  std::string authFile;  ///< a file of credentials; "" for VOXBRICK_DICOMWEB_AUTH, else none
  /// Where the instances are fetched to, in a folder of their own removed with the source; "" for the system's
  /// temporary directory.
  std::string downloadDir;
  double timeoutSeconds = 30;       ///< to connect, and the longest a transfer may receive nothing
  int retries = 3;                  ///< further attempts of a request that failed in a way a retry may mend
  int connections = 4;              ///< instances fetched at a time
  double maxMBPerSecond = 0;        ///< the receive rate of all connections together; 0 for no limit
  std::function<bool()> cancelled;  ///< polled while fetching; true stops it ("interrupted")
  /// Called (from one thread at a time) as instances arrive: done of total, and the bytes received so far.
  std::function<void(int64_t done, int64_t total, uint64_t bytes)> onFetched;
};

/// Options a user gives prep for inputs whose files do not describe themselves (raw) or to override them.
struct SourceOptions {
  Vec3i dims;                  ///< raw: required
  std::string type;            ///< raw: required ("u8", "u16", "i16", "f32")
  Vec3d spacing;               ///< raw: default 1,1,1
  bool spacingGiven = false;   ///< true if spacing overrides the file's own
  bool bigEndian = false;      ///< raw: byte order of the file
  int64_t headerBytes = 0;     ///< raw: bytes to skip before the voxels
  std::string gridName;        ///< vdb: grid to read (default: the first float grid)
  std::string seriesUid;       ///< dicom: the SeriesInstanceUID to read when the input holds several
  int64_t memoryBudgetMB = 0;  ///< prep's --memory: a declared slice that cannot fit is refused at open (0: none)
  int64_t time = 0;            ///< OME-Zarr: the index along its 't' axis
  int64_t channel = 0;         ///< OME-Zarr: the index along its 'c' axis
  DicomWebOptions dicomWeb;    ///< dicomweb:// inputs
};

/// Throws InputError naming `file` and the header `field` that declares the slice size when one z-slice of nx x ny
/// values of `valueBytes` bytes cannot fit twice (the file's and the store's copy) in options.memoryBudgetMB beside
/// the process itself: a declared size beyond --memory is refused before anything is allocated from it. Nothing is
/// checked when memoryBudgetMB is 0.
void checkSliceFitsMemory(int64_t nx, int64_t ny, size_t valueBytes, const SourceOptions& options,
                          const std::string& file, const std::string& field);

}  // namespace voxbrick::store
