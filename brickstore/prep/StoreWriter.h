// `voxbrick prep`: streams a VolumeSource into a new store (bricks, octree ranges, LOD pyramid, VDB grid, metadata).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "brickstore/format/StoreMeta.h"
#include "brickstore/prep/Level0Stats.h"
#include "brickstore/prep/PhaseClock.h"
#include "brickstore/prep/VdbChunkWriter.h"
#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

struct PrepOptions {
  int brickSize = 32;             ///< B: a power of two in [8, 256]
  int zstdLevel = 1;              ///< zstd level for brick frames (1: decodes faster than 3, for a few % more bytes)
  int64_t memoryBudgetMB = 1024;  ///< bound on the slab window and per-chunk VDB grid; checked before starting
  bool haveBackground = false;    ///< if false, the source's background is used
  double background = 0.0;
  NonFinitePolicy nonFinite = NonFinitePolicy::Background;
  bool writeVdb = true;        ///< write the canonical OpenVDB grid
  int64_t vdbChunkSlices = 0;  ///< z-slices per VDB file; 0: as many as the memory budget allows
  /// How the VDB files store leaf values. Blosc gives about 0.85 of the size on noisy float data (a fifth of prep's
  /// CPU when every voxel is active) and a third on a smooth MRI; Auto uses it per chunk where it halves the bytes.
  /// Readers take any.
  VdbCompression vdbCompression = VdbCompression::Auto;
  bool overwrite = false;  ///< replace an existing store (only once the new one is complete)
  int threads = 0;         ///< worker threads; 0 = hardware concurrency
  /// Store u8 or u16 values: the input mapped linearly from quantise->lo..hi (scanLevel0 gives the input's exact
  /// range). Non-finite values take the background first; the background is quantised too.
  std::optional<Quantisation> quantise;
};

/// Progress of a running prep, for a progress bar.
struct PrepProgress {
  std::string stage;            ///< "level 0", "level 1", ..., "histogram"
  int64_t done = 0, total = 0;  ///< units of the stage (slices)
  int64_t bytesIn = 0;          ///< input bytes consumed so far (level 0)
};

/// What a finished prep reports.
struct PrepSummary {
  StoreMeta meta;
  double seconds = 0;
  int64_t bytesIn = 0;       ///< input voxel bytes read
  int64_t peakRssBytes = 0;  ///< the process's peak resident set size when prep finished
  double cpuSeconds = 0;     ///< the process's CPU time (user + system, all threads) during prep
  /// Where the time went, in order: level 0 (less the time it waited for grid files), the histogram where the input
  /// is read again, the coarser levels, the time spent waiting for grid files not written behind other work (when
  /// written), and the end (fsync, index, metadata). The swap into place is not counted.
  std::vector<PhaseTime> phases;
};

/// Writes the store for `source` at `output`. The store is built under a temporary name beside `output` and
/// renamed into place only when complete; on any error the temporary is removed and an existing store at `output`
/// is untouched. Throws InputError, IoError or StoreError naming the file and the problem.
PrepSummary prepStore(VolumeSource& source, const std::filesystem::path& output, const PrepOptions& options,
                      const std::function<void(const PrepProgress&)>& progress = {});

}  // namespace voxbrick::store
