// prep: level 0 from the source (with the non-finite policy, statistics and the VDB grid), then each coarser
// level from the one before, then the index and metadata, all in a directory beside the store swapped into place.
#include "brickstore/prep/StoreWriter.h"

#include <sys/resource.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>

#include "brickstore/format/BrickFile.h"
#include "brickstore/format/Errors.h"
#include "brickstore/format/HistogramBuilder.h"
#include "brickstore/prep/Level0Stats.h"
#include "brickstore/prep/LevelSources.h"
#include "brickstore/prep/PhaseClock.h"
#include "brickstore/prep/QuantisingSource.h"
#include "brickstore/prep/SlabBricker.h"
#include "brickstore/prep/VdbChunkWriter.h"
#include "common/AtomicReplace.h"
#include "common/Checksum.h"
#include "common/OutputFile.h"

namespace voxbrick::store {
namespace fs = std::filesystem;
namespace {

/// Level 1's scratch file in the store being built, while level 0's pass makes it (see FirstPass).
constexpr const char* kLevel1Scratch = "level1.scratch";

/// Slabs in flight at most: one being read while one is cut and one written is all two cores can overlap.
constexpr int kMaxSlabsInFlight = 3;

/// How many slabs of `slabBytes` fit in `freeBytes`, in [1, cap].
int slabsInFlight(int64_t freeBytes, int64_t slabBytes, int cap) {
  return static_cast<int>(std::clamp<int64_t>(freeBytes / std::max<int64_t>(1, slabBytes), 1, cap));
}

void validate(const VolumeInfo& info, const PrepOptions& options, double background) {
  checkBrickSize(options.brickSize);
  if (options.zstdLevel < -7 || options.zstdLevel > 22)
    throw InputError("--zstd-level " + std::to_string(options.zstdLevel) + " is outside [-7, 22]");
  if (info.dims.x <= 0 || info.dims.y <= 0 || info.dims.z <= 0)
    throw InputError(info.description + ": zero or negative dims");
  for (int a = 0; a < 3; ++a)
    if (!(info.spacing[a] > 0) || !std::isfinite(info.spacing[a]))
      throw InputError(info.description + ": spacing must be positive and finite");
  if (!std::isfinite(background)) throw InputError("background value must be finite");
  if (info.type != ValueType::F32) {
    double lo = info.type == ValueType::U8 ? 0 : (info.type == ValueType::U16 ? 0 : -32768);
    double hi = info.type == ValueType::U8 ? 255 : (info.type == ValueType::U16 ? 65535 : 32767);
    if (background < lo || background > hi || background != std::floor(background))
      throw InputError("background " + std::to_string(background) + " is not a " +
                       std::string(valueTypeName(info.type)) + " value");
  }
  // Brick indices are stored as uint32 and VDB coordinates as int32.
  constexpr int64_t kMaxDim = int64_t{1} << 30;
  if (info.dims.x > kMaxDim || info.dims.y > kMaxDim || info.dims.z > kMaxDim)
    throw InputError(info.description + ": a dimension exceeds 2^30 voxels");
}

/// This process's own peak: VmHWM of /proc/self/status. (getrusage's ru_maxrss also counts the parent's resident set
/// at the fork, so a prep started by a process holding a large array, such as a Python kernel, would report that.)
/// ru_maxrss where /proc cannot say.
int64_t peakRssBytes() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmHWM:", 0) == 0) return std::stoll(line.substr(6)) * 1024;  // "VmHWM:   123456 kB"
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<int64_t>(usage.ru_maxrss) * 1024;
}

/// The level-0 histogram counted on every thread: a HistogramBuilder per thread, merged at the end (counts do not
/// depend on the order).
class ParallelHistogram {
 public:
  ParallelHistogram(ValueType type, double lo, double hi)
      : mType(type), mLo(lo), mHi(hi), mBuilders([type, lo, hi] { return HistogramBuilder(type, lo, hi); }) {}

  void add(const void* values, int64_t count) {
    const auto* bytes = static_cast<const std::byte*>(values);
    const size_t size = valueSize(mType);
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, count, int64_t{1} << 16), [&](const auto& r) {
      mBuilders.local().add(bytes + size_t(r.begin()) * size, r.end() - r.begin());
    });
  }

  /// The histogram over [lo, hi]: the range given at construction for floats (binned as they come); integer types,
  /// counted by value, may be given their range only now.
  Histogram finish(double lo, double hi) {
    HistogramBuilder all(mType, lo, hi);
    for (const HistogramBuilder& b : mBuilders) all.merge(b);
    return all.finish();
  }

 private:
  ValueType mType;
  double mLo, mHi;
  tbb::enumerable_thread_specific<HistogramBuilder> mBuilders;
};

void writeIndex(const fs::path& path, const std::vector<LevelBuild>& levels, int B, ValueType type,
                uint64_t bricksFileSize) {
  std::vector<char> body;
  uint64_t first = 0;
  for (const LevelBuild& l : levels) {
    LevelEntry e{};
    e.dims[0] = l.dims.x, e.dims[1] = l.dims.y, e.dims[2] = l.dims.z;
    e.bricks[0] = uint32_t(l.bricks.x), e.bricks[1] = uint32_t(l.bricks.y), e.bricks[2] = uint32_t(l.bricks.z);
    e.firstRecord = first;
    first += l.records.size();
    body.insert(body.end(), reinterpret_cast<const char*>(&e), reinterpret_cast<const char*>(&e) + sizeof e);
  }
  for (const LevelBuild& l : levels) {
    const char* p = reinterpret_cast<const char*>(l.records.data());
    body.insert(body.end(), p, p + l.records.size() * sizeof(BrickRecord));
  }
  IndexHeader h{};
  std::copy(std::begin(kIndexMagic), std::end(kIndexMagic), h.magic);
  h.version = kIndexVersion;
  h.levelCount = uint32_t(levels.size());
  h.brickSize = uint32_t(B);
  h.valueType = uint32_t(type);
  h.bricksFileSize = bricksFileSize;
  h.recordCount = first;
  h.bodyCrc32 = common::crc32Of(body.data(), body.size());
  h.headerCrc32 = common::crc32Of(&h, offsetof(IndexHeader, headerCrc32));
  common::OutputFile out(path, throwIoError);
  out.append(&h, sizeof h);
  out.append(body.data(), body.size());
  out.close();
}

bool looksLikeStore(const fs::path& dir) {
  std::error_code ec;
  return fs::is_directory(dir, ec) && (fs::exists(dir / "store.json", ec) || fs::exists(dir / "index.bin", ec));
}

/// An existing `output` is replaced only with --force, and only if it is a store.
void checkOutput(const fs::path& output, const PrepOptions& options) {
  std::error_code ec;
  if (!fs::exists(output, ec)) return;
  if (!options.overwrite) throw InputError(output.string() + ": already exists (use --force to replace it)");
  if (!looksLikeStore(output))
    throw InputError(output.string() + ": exists and is not a voxbrick store; refusing to replace it");
}

/// How a prep's memory is shared out (see planMemory).
struct MemoryPlan {
  int64_t budget = 0;       ///< bytes for the buffers: --memory less the process's baseline and the quantiser's staging
  int64_t chunkSlices = 0;  ///< z-slices a VDB file
  int maxInFlight = 1;      ///< slabs in flight at most, by the threads
  int level0InFlight = 1;   ///< slabs in flight for level 0
};

/// Memory plan: the slab window, one slab of compressed frames, and (with the VDB grid) one chunk of it; more slabs
/// in flight (reading ahead while one is cut) only from what is left after that, so the chunk size (and so the
/// files written) does not depend on the threads. Throws InputError when --memory cannot hold one slab and chunk.
MemoryPlan planMemory(const VolumeInfo& info, const PrepOptions& options, int64_t stagingBytes) {
  // The process itself (libraries, allocator, thread stacks) takes about this much before any buffer: an idle
  // `voxbrick --version` is 97 MB resident on Debian 12 (OpenVDB, TBB, Mesa, GDCM and the rest mapped), so --memory is
  // a bound on the whole process's peak RSS. A constant, not a measurement, so that the chunking (the files written)
  // depends on the options alone.
  constexpr int64_t kBaselineBytes = int64_t{112} << 20;
  const int B = options.brickSize;
  MemoryPlan plan;
  plan.budget = options.memoryBudgetMB * 1024 * 1024 - kBaselineBytes - stagingBytes;
  const int64_t slab = SlabBricker::slabBytes(info.dims, B, info.type);
  plan.chunkSlices = info.dims.z;
  if (options.writeVdb) {
    const int64_t left = plan.budget - slab;
    const int64_t slabs = left / std::max<int64_t>(1, VdbChunkWriter::chunkBytes(info.dims, B));
    plan.chunkSlices = std::min(info.dims.z, slabs * B);
    if (slabs < 1) plan.chunkSlices = 0;
    if (options.vdbChunkSlices > 0) plan.chunkSlices = std::min(plan.chunkSlices, options.vdbChunkSlices);
  }
  const int64_t needed = slab + (options.writeVdb ? VdbChunkWriter::chunkBytes(info.dims, B) : 0);
  if (needed > plan.budget || plan.chunkSlices <= 0)
    throw InputError("--memory " + std::to_string(options.memoryBudgetMB) + " MB is too small for slices of " +
                     std::to_string(info.dims.x) + "x" + std::to_string(info.dims.y) + " voxels with --brick " +
                     std::to_string(B) + ": needs at least " + std::to_string(divUp(needed + kBaselineBytes, 1 << 20)) +
                     " MB");
  plan.maxInFlight =
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism) > 1 ? kMaxSlabsInFlight : 1;
  // The chunk is sized by its planning estimate (so the files depend on the options alone), but holds less: what
  // is left reads slabs ahead while others are cut and the chunk is written.
  const int64_t vdbBytes = options.writeVdb ? VdbChunkWriter::residentBytes(info.dims, plan.chunkSlices) : 0;
  plan.level0InFlight = slabsInFlight(plan.budget - vdbBytes, slab, plan.maxInFlight);
  return plan;
}

/// What the steps of a prep share. `info` and `background` describe what is stored: the input, or the input
/// quantised (then `quantised` is the source that does it).
struct PrepPlan {
  const PrepOptions& options;
  const VolumeInfo& input;
  VolumeSource& level0Source;
  QuantisingSource* quantised;
  const VolumeInfo& info;
  double background;
  MemoryPlan memory;
};

/// Hands a running prep's progress to the caller's callback, if there is one.
class ProgressReport {
 public:
  explicit ProgressReport(const std::function<void(const PrepProgress&)>& progress) : mProgress(progress) {}
  void operator()(const std::string& stage, int64_t done, int64_t total) {
    if (!mProgress) return;
    mState.stage = stage;
    mState.done = done;
    mState.total = total;
    mProgress(mState);
  }
  void addBytesIn(int64_t bytes) { mState.bytesIn += bytes; }
  int64_t bytesIn() const { return mState.bytesIn; }

 private:
  const std::function<void(const PrepProgress&)>& mProgress;
  PrepProgress mState;
};

/// The metadata known before any voxel is read.
StoreMeta describeStore(const PrepPlan& plan) {
  const VolumeInfo& info = plan.info;
  StoreMeta meta;
  meta.dims = info.dims;
  meta.spacing = info.spacing;
  meta.orientation = info.orientation;
  meta.type = info.type;
  meta.background = plan.background;
  meta.brickSize = plan.options.brickSize;
  meta.bytesRaw = info.dims.volume() * static_cast<int64_t>(valueSize(info.type));
  meta.source = info.description;
  return meta;
}

/// Level 0 from the source into `bricks` (and the VDB grid into `dir`); its statistics, VDB files and quantisation
/// go into `meta`.
LevelBuild writeLevel0(const PrepPlan& plan, const fs::path& dir, common::OutputFile& bricks, StoreMeta& meta,
                       ProgressReport& report, std::vector<PhaseTime>& phases, const SlabBricker::SliceConsumer& tap,
                       std::unique_ptr<VdbChunkWriter>& vdb) {
  const PhaseClock clock;
  const PrepOptions& options = plan.options;
  const VolumeInfo& info = plan.info;
  Level0Stats stats(info, plan.background, options.nonFinite);
  if (options.writeVdb)
    vdb = VdbChunkWriter::make(dir, info, plan.background, plan.memory.chunkSlices, options.vdbCompression);
  SlabBricker bricker(plan.level0Source, options.brickSize, plan.background, options.zstdLevel, bricks);
  bricker.setSlabsInFlight(plan.memory.level0InFlight);
  const int64_t sliceBytes = plan.input.dims.x * plan.input.dims.y * static_cast<int64_t>(valueSize(plan.input.type));
  bricker.setSliceHook([&](int64_t z0, int64_t count, void* values) {
    stats.observe(z0, count, values);
    report.addBytesIn(count * sliceBytes);
  });
  if (vdb && tap)
    bricker.setSliceConsumer([&](int64_t z0, int64_t count, const void* values) {
      tbb::parallel_invoke([&] { vdb->addSlices(z0, count, values); }, [&] { tap(z0, count, values); });
    });
  else if (vdb)
    bricker.setSliceConsumer([&](int64_t z0, int64_t count, const void* values) { vdb->addSlices(z0, count, values); });
  else if (tap)
    bricker.setSliceConsumer(tap);
  bricker.setProgressHook([&](int64_t done, int64_t total) { report("level 0", done, total); });
  LevelBuild level = bricker.run();
  if (vdb) vdb->finish();  // the last file is written while the steps after level 0 run
  PhaseTime all = clock.elapsed(vdb ? "level 0: read, bricks, grid cut" : "level 0: read, bricks");
  if (vdb) {  // the time the slices waited for a chunk's file is the writer's, and said so at the end
    all.wallSeconds -= vdb->writeTime().wallSeconds;
    all.cpuSeconds -= vdb->writeTime().cpuSeconds;
  }
  phases.push_back(all);
  meta.valueMin = stats.min;
  meta.valueMax = stats.max;
  meta.activeVoxels = stats.active;
  meta.nonFiniteReplaced = plan.quantised ? plan.quantised->innerStats().nonFinite : stats.nonFinite;
  if (plan.quantised) {
    meta.quantisation = options.quantise;
    meta.quantisationClamped = plan.quantised->clamped();
  }
  return level;
}

/// What level 0's pass also makes, when it can, so that level 0 is not read back: level 1 (spilled to a scratch file)
/// and the histogram. It can for integer types (counted by value, binned at the end) and for a float input that can
/// be read again cheaply: its histogram, which needs level 0's range, is counted from the input read again after.
struct FirstPass {
  std::unique_ptr<VolumeSource> again;         ///< the float input, to be read again for the histogram
  std::optional<ParallelHistogram> histogram;  ///< counted in level 0's pass (integer types) or after it (floats)
  std::unique_ptr<Level1Spill> level1;         ///< null when level 0 is the only level
};

/// Sets up `pass` when level 0's pass can make level 1 and the histogram can be counted without reading level 0
/// back; false when it cannot.
bool planFirstPass(const PrepPlan& plan, const fs::path& dir, FirstPass& pass) {
  const VolumeInfo& info = plan.info;
  if (info.type == ValueType::F32) {
    pass.again = plan.quantised ? nullptr : plan.level0Source.reopen();
    if (!pass.again) return false;
  } else {
    pass.histogram.emplace(info.type, 0.0, 0.0);
  }
  const std::vector<Vec3i> pyramid = pyramidDims(info.dims, plan.options.brickSize);
  // Level 1 from level 0's pass, unless the input brings its own (an OME-Zarr's pyramid).
  if (pyramid.size() > 1 && (plan.quantised || !plan.level0Source.ownLevel(1, pyramid[1])))
    pass.level1 = std::make_unique<Level1Spill>(info, dir / kLevel1Scratch);
  return true;
}

/// The float histogram of `meta`'s range counted from the input read again, with the non-finite policy applied as
/// level 0's pass applied it.
void countHistogramAgain(const PrepPlan& plan, FirstPass& pass, const StoreMeta& meta, ProgressReport& report) {
  const VolumeInfo& info = plan.info;
  ParallelHistogram& histogram = pass.histogram.emplace(info.type, meta.valueMin, meta.valueMax);
  // Batches of a few MB (at least a slice: a slab of B + 2 fits the budget) that stay in cache to be counted.
  const int64_t sliceValues = info.dims.x * info.dims.y;
  const int64_t batch =
      std::clamp<int64_t>(std::min(plan.memory.budget / 8, int64_t{2} << 20) / (sliceValues * 4), 1, info.dims.z);
  std::vector<float> values(static_cast<size_t>(batch * sliceValues));
  const float background = static_cast<float>(plan.background);
  for (int64_t z = 0; z < info.dims.z; z += batch) {
    const int64_t count = std::min(batch, info.dims.z - z);
    pass.again->readSlices(count, values.data());
    if (meta.nonFiniteReplaced > 0)
      for (float& v : values) v = std::isfinite(v) ? v : background;
    histogram.add(values.data(), count * sliceValues);
    report("histogram", z + count, info.dims.z);
  }
}

/// Coarser levels appended to `bricks` and `levels`: level 1 from `pass`'s scratch file if it was made, else from
/// level 0 read back (in `dir`/bricks.bin), whose pass also counts the histogram of `meta`'s value range; each
/// level after from the one before, read back. Returns the histogram.
Histogram writeCoarserLevels(const PrepPlan& plan, const fs::path& dir, common::OutputFile& bricks,
                             std::vector<LevelBuild>& levels, const StoreMeta& meta, ProgressReport& report,
                             FirstPass* pass) {
  const VolumeInfo& info = plan.info;
  const int B = plan.options.brickSize;
  const std::vector<Vec3i> pyramid = pyramidDims(info.dims, B);
  std::optional<ParallelHistogram> readBack;
  if (!pass) readBack.emplace(info.type, meta.valueMin, meta.valueMax);
  BrickFileReader reader(dir / "bricks.bin", info.type);
  auto histogramHook = [&](int64_t, int64_t count, const void* values) {
    readBack->add(values, count * info.dims.x * info.dims.y);
  };
  for (size_t l = 1; l < pyramid.size(); ++l) {
    // The input's own level (an OME-Zarr's), where it has one of these dims; never for a quantised input.
    std::unique_ptr<VolumeSource> own =
        plan.quantised ? nullptr : plan.level0Source.ownLevel(static_cast<int>(l), pyramid[l]);
    std::optional<StoredLevelSource> finer;
    std::optional<DownsampleSource> downsampled;
    std::unique_ptr<VolumeSource> spilled;
    VolumeSource* coarse = nullptr;
    if (own) {
      coarse = own.get();
      if (l == 1 && readBack) {  // level 0 is still read back once, for the histogram
        StoredLevelSource level0(reader, levels[0], 0, B, info.type, plan.background, info.spacing);
        level0.setSliceHook(histogramHook);
        std::vector<char> slice(static_cast<size_t>(info.dims.x * info.dims.y) * valueSize(info.type));
        for (int64_t z = 0; z < info.dims.z; ++z) level0.readSlices(1, slice.data());
      }
    } else if (l == 1 && pass && pass->level1) {
      spilled = pass->level1->spilled();
      coarse = spilled.get();
    } else {
      finer.emplace(reader, levels[l - 1], uint32_t(l - 1), B, info.type, plan.background, info.spacing);
      if (l == 1 && readBack) finer->setSliceHook(histogramHook);
      coarse = &downsampled.emplace(*finer);
    }
    SlabBricker bricker(*coarse, B, plan.background, plan.options.zstdLevel, bricks);
    // The finer level's slab of B slices and the downsampler's two are held beside the slabs in flight.
    const int64_t finerSlices = (B + 2) * pyramid[l - 1].x * pyramid[l - 1].y * int64_t(valueSize(info.type));
    bricker.setSlabsInFlight(slabsInFlight(plan.memory.budget - finerSlices,
                                           SlabBricker::slabBytes(pyramid[l], B, info.type), plan.memory.maxInFlight));
    const std::string stage = "level " + std::to_string(l);
    bricker.setProgressHook([&](int64_t done, int64_t total) { report(stage, done, total); });
    levels.push_back(bricker.run());
    if (spilled) {
      spilled.reset();
      pass->level1.reset();
      fs::remove(dir / kLevel1Scratch);
    }
  }
  if (pass) return pass->histogram->finish(meta.valueMin, meta.valueMax);
  if (pyramid.size() == 1) {
    StoredLevelSource only(reader, levels[0], 0, B, info.type, plan.background, info.spacing);
    only.setSliceHook(histogramHook);
    std::vector<char> slice(static_cast<size_t>(info.dims.x * info.dims.y) * valueSize(info.type));
    for (int64_t z = 0; z < info.dims.z; ++z) only.readSlices(1, slice.data());
  }
  return readBack->finish(meta.valueMin, meta.valueMax);
}

/// The whole store into the empty directory `dir`: the levels' bricks, the index and store.json; returns its
/// metadata.
StoreMeta writeStore(const PrepPlan& plan, const fs::path& dir, ProgressReport& report,
                     std::vector<PhaseTime>& phases) {
  StoreMeta meta = describeStore(plan);
  FirstPass pass;
  const bool firstPass = planFirstPass(plan, dir, pass);
  SlabBricker::SliceConsumer tap;
  if (firstPass)
    tap = [&](int64_t z0, int64_t count, const void* values) {
      tbb::parallel_invoke(
          [&] {
            if (pass.histogram) pass.histogram->add(values, count * plan.info.dims.x * plan.info.dims.y);
          },
          [&] {
            if (pass.level1) pass.level1->addSlices(z0, count, values);
          });
    };
  common::OutputFile bricks(dir / "bricks.bin", throwIoError);
  std::vector<LevelBuild> levels;
  std::unique_ptr<VdbChunkWriter> vdb;
  levels.push_back(writeLevel0(plan, dir, bricks, meta, report, phases, tap, vdb));
  if (pass.again) {
    const PhaseClock histogramClock;
    countHistogramAgain(plan, pass, meta, report);
    phases.push_back(histogramClock.elapsed("histogram (input read again)"));
  }
  PhaseClock clock;
  meta.histogram = writeCoarserLevels(plan, dir, bricks, levels, meta, report, firstPass ? &pass : nullptr);
  phases.push_back(clock.elapsed(firstPass ? "levels 1+ (level 1 from level 0's pass)"
                                           : "levels 1+ (level 0 read back) and histogram"));
  clock.restart();
  const uint64_t bricksSize = bricks.size();
  bricks.close();
  writeIndex(dir / "index.bin", levels, plan.options.brickSize, plan.info.type, bricksSize);
  PhaseTime end = clock.elapsed("");
  if (vdb) {
    vdb->wait();
    meta.vdbFiles = vdb->files();
    meta.bytesVdb = vdb->bytes();
    phases.push_back(vdb->writeTime());
    vdb.reset();
  }
  clock.restart();
  meta.bytesStored = int64_t(bricksSize) + int64_t(fs::file_size(dir / "index.bin"));
  for (const LevelBuild& l : levels) meta.levels.push_back({l.dims, l.bricks, l.bricksStored, l.bytesStored});
  common::OutputFile json(dir / "store.json", throwIoError);
  const std::string text = meta.toJson();
  json.append(text.data(), text.size());
  json.close();
  const PhaseTime described = clock.elapsed("");
  phases.push_back({"bricks.bin fsync, index, store.json", end.wallSeconds + described.wallSeconds,
                    end.cpuSeconds + described.cpuSeconds});
  return meta;
}

}  // namespace

PrepSummary prepStore(VolumeSource& source, const fs::path& output, const PrepOptions& options,
                      const std::function<void(const PrepProgress&)>& progress) {
  const auto start = std::chrono::steady_clock::now();
  const double cpuStart = PhaseClock::processCpuSeconds();
  const VolumeInfo& input = source.info();
  const double inputBackground = options.haveBackground ? options.background : input.background;
  validate(input, options, inputBackground);
  std::optional<QuantisingSource> quantised;
  if (options.quantise) quantised.emplace(source, *options.quantise, inputBackground, options.nonFinite);
  VolumeSource& level0Source = quantised ? static_cast<VolumeSource&>(*quantised) : source;
  std::optional<tbb::global_control> threadLimit;
  if (options.threads > 0)
    threadLimit.emplace(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(options.threads));
  checkOutput(output, options);
  const VolumeInfo& info = level0Source.info();
  const PrepPlan plan{options,
                      input,
                      level0Source,
                      quantised ? &*quantised : nullptr,
                      info,
                      quantised ? info.background : inputBackground,
                      planMemory(info, options, quantised ? quantised->stagingBytes() : 0)};

  // Built beside `output`, then swapped in: an existing store stays at the path until the new one replaces it.
  ProgressReport report(progress);
  PrepSummary summary;
  try {
    common::replaceDirectory(
        output, [&](const fs::path& dir) { summary.meta = writeStore(plan, dir, report, summary.phases); });
  } catch (const common::ReplaceError& e) {
    throw IoError(e.what());
  }
  summary.bytesIn = report.bytesIn();
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary.cpuSeconds = PhaseClock::processCpuSeconds() - cpuStart;
  summary.peakRssBytes = peakRssBytes();
  return summary;
}

}  // namespace voxbrick::store
