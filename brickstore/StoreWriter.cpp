// prep: level 0 from the source (with the non-finite policy, statistics and the VDB grid), then each coarser
// level from the one before, then the index and metadata, then an atomic rename into place.
#include "brickstore/StoreWriter.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <type_traits>

#include "brickstore/BrickFile.h"
#include "brickstore/Errors.h"
#include "brickstore/HistogramBuilder.h"
#include "brickstore/Level0Stats.h"
#include "brickstore/LevelSources.h"
#include "brickstore/Quantise.h"
#include "brickstore/SlabBricker.h"
#include "brickstore/VdbChunkWriter.h"

namespace voxbrick::store {
namespace fs = std::filesystem;
namespace {

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

int64_t peakRssBytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<int64_t>(usage.ru_maxrss) * 1024;
}

void syncDirectory(const fs::path& dir) {
  int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
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

  Histogram finish() {
    HistogramBuilder all(mType, mLo, mHi);
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
  h.bodyCrc32 = crc32Of(body.data(), body.size());
  h.headerCrc32 = crc32Of(&h, offsetof(IndexHeader, headerCrc32));
  OutputFile out(path);
  out.append(&h, sizeof h);
  out.append(body.data(), body.size());
  out.close();
}

/// Removes the temporary store unless release() was called.
class TempDirGuard {
 public:
  explicit TempDirGuard(fs::path dir) : mDir(std::move(dir)) {}
  ~TempDirGuard() {
    std::error_code ec;
    if (!mDir.empty()) fs::remove_all(mDir, ec);
  }
  void release() { mDir.clear(); }

 private:
  fs::path mDir;
};

bool looksLikeStore(const fs::path& dir) {
  std::error_code ec;
  return fs::is_directory(dir, ec) && (fs::exists(dir / "store.json", ec) || fs::exists(dir / "index.bin", ec));
}

}  // namespace

PrepSummary prepStore(VolumeSource& source, const fs::path& output, const PrepOptions& options,
                      const std::function<void(const PrepProgress&)>& progress) {
  const auto start = std::chrono::steady_clock::now();
  const VolumeInfo& input = source.info();
  const double inputBackground = options.haveBackground ? options.background : input.background;
  validate(input, options, inputBackground);
  // From here on `info` and `background` describe what is stored: the input, or the input quantised.
  std::optional<QuantisingSource> quantised;
  if (options.quantise) quantised.emplace(source, *options.quantise, inputBackground, options.nonFinite);
  VolumeSource& level0Source = quantised ? static_cast<VolumeSource&>(*quantised) : source;
  const VolumeInfo& info = level0Source.info();
  const double background = quantised ? info.background : inputBackground;
  const int B = options.brickSize;
  std::optional<tbb::global_control> threadLimit;
  if (options.threads > 0)
    threadLimit.emplace(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(options.threads));

  std::error_code ec;
  if (fs::exists(output, ec)) {
    if (!options.overwrite) throw InputError(output.string() + ": already exists (use --force to replace it)");
    if (!looksLikeStore(output))
      throw InputError(output.string() + ": exists and is not a voxbrick store; refusing to replace it");
  }

  // Memory plan: the slab window, one slab of compressed frames, and (with the VDB grid) one chunk of it; more slabs
  // in flight (reading ahead while one is cut) only from what is left after that, so the chunk size (and so the
  // files written) does not depend on the threads.
  // The process itself (libraries, allocator, thread stacks) takes about this much before any buffer: an idle
  // `voxbrick --version` is 97 MB resident on Debian 12 (OpenVDB, TBB, Mesa, GDCM and the rest mapped), so --memory is a
  // bound on the whole process's peak RSS. A constant, not a measurement, so that the chunking (the files written)
  // depends on the options alone.
  constexpr int64_t kBaselineBytes = int64_t{112} << 20;
  const int64_t budget =
      options.memoryBudgetMB * 1024 * 1024 - kBaselineBytes - (quantised ? quantised->stagingBytes() : 0);
  const int64_t slab = SlabBricker::slabBytes(info.dims, B, info.type);
  int64_t chunkSlices = info.dims.z;
  if (options.writeVdb) {
    const int64_t left = budget - slab;
    const int64_t slabs = left / std::max<int64_t>(1, VdbChunkWriter::chunkBytes(info.dims, B));
    chunkSlices = std::min(info.dims.z, slabs * B);
    if (slabs < 1) chunkSlices = 0;
    if (options.vdbChunkSlices > 0) chunkSlices = std::min(chunkSlices, options.vdbChunkSlices);
  }
  const int64_t needed = slab + (options.writeVdb ? VdbChunkWriter::chunkBytes(info.dims, B) : 0);
  if (needed > budget || chunkSlices <= 0)
    throw InputError("--memory " + std::to_string(options.memoryBudgetMB) + " MB is too small for slices of " +
                     std::to_string(info.dims.x) + "x" + std::to_string(info.dims.y) + " voxels with --brick " +
                     std::to_string(B) + ": needs at least " + std::to_string(divUp(needed + kBaselineBytes, 1 << 20)) + " MB");
  const int maxInFlight =
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism) > 1 ? kMaxSlabsInFlight : 1;
  const int64_t vdbBytes = options.writeVdb ? VdbChunkWriter::chunkBytes(info.dims, chunkSlices) : 0;
  const int level0InFlight = slabsInFlight(budget - vdbBytes, slab, maxInFlight);

  const fs::path parent = output.has_parent_path() ? output.parent_path() : fs::path(".");
  const fs::path tmp = parent / ("." + output.filename().string() + ".tmp-" + std::to_string(::getpid()));
  fs::remove_all(tmp, ec);
  if (!fs::create_directory(tmp, ec) || ec)
    throw IoError("cannot create " + tmp.string() + ": " + (ec ? ec.message() : std::string("already exists")));
  TempDirGuard guard(tmp);

  StoreMeta meta;
  meta.dims = info.dims;
  meta.spacing = info.spacing;
  meta.orientation = info.orientation;
  meta.type = info.type;
  meta.background = background;
  meta.brickSize = B;
  meta.bytesRaw = info.dims.volume() * static_cast<int64_t>(valueSize(info.type));
  meta.source = info.description;

  OutputFile bricks(tmp / "bricks.bin");
  std::vector<LevelBuild> levels;
  PrepProgress state;
  const std::vector<Vec3i> pyramid = pyramidDims(info.dims, B);
  auto report = [&](const std::string& stage, int64_t done, int64_t total) {
    if (!progress) return;
    state.stage = stage;
    state.done = done;
    state.total = total;
    progress(state);
  };

  // Level 0.
  {
    Level0Stats stats(info, background, options.nonFinite);
    std::unique_ptr<VdbChunkWriter> vdb;
    if (options.writeVdb) vdb = std::make_unique<VdbChunkWriter>(tmp, info, background, chunkSlices);
    SlabBricker bricker(level0Source, B, background, options.zstdLevel, bricks);
    bricker.setSlabsInFlight(level0InFlight);
    const int64_t sliceBytes = input.dims.x * input.dims.y * static_cast<int64_t>(valueSize(input.type));
    bricker.setSliceHook([&](int64_t z0, int64_t count, void* values) {
      stats.observe(z0, count, values);
      state.bytesIn += count * sliceBytes;
    });
    if (vdb)
      bricker.setSliceConsumer([&](int64_t z0, int64_t count, const void* values) { vdb->addSlices(z0, count, values); });
    bricker.setProgressHook([&](int64_t done, int64_t total) { report("level 0", done, total); });
    levels.push_back(bricker.run());
    if (vdb) {
      vdb->finish();
      meta.vdbFiles = vdb->files();
      meta.bytesVdb = vdb->bytes();
    }
    meta.valueMin = stats.min;
    meta.valueMax = stats.max;
    meta.activeVoxels = stats.active;
    meta.nonFiniteReplaced = quantised ? quantised->innerStats().nonFinite : stats.nonFinite;
    if (quantised) {
      meta.quantisation = options.quantise;
      meta.quantisationClamped = quantised->clamped();
    }
  }

  // Coarser levels, each read back from the one before; the pass over level 0 also fills the histogram.
  ParallelHistogram histogram(info.type, meta.valueMin, meta.valueMax);
  BrickFileReader reader(tmp / "bricks.bin", info.type);
  auto histogramHook = [&](int64_t, int64_t count, const void* values) {
    histogram.add(values, count * info.dims.x * info.dims.y);
  };
  for (size_t l = 1; l < pyramid.size(); ++l) {
    StoredLevelSource finer(reader, levels[l - 1], uint32_t(l - 1), B, info.type, background, info.spacing);
    if (l == 1) finer.setSliceHook(histogramHook);
    DownsampleSource coarse(finer);
    SlabBricker bricker(coarse, B, background, options.zstdLevel, bricks);
    // The finer level's slab of B slices and the downsampler's two are held beside the slabs in flight.
    const int64_t finerSlices = (B + 2) * pyramid[l - 1].x * pyramid[l - 1].y * int64_t(valueSize(info.type));
    bricker.setSlabsInFlight(slabsInFlight(budget - finerSlices, SlabBricker::slabBytes(pyramid[l], B, info.type),
                                           maxInFlight));
    const std::string stage = "level " + std::to_string(l);
    bricker.setProgressHook([&](int64_t done, int64_t total) { report(stage, done, total); });
    levels.push_back(bricker.run());
  }
  if (pyramid.size() == 1) {
    StoredLevelSource only(reader, levels[0], 0, B, info.type, background, info.spacing);
    only.setSliceHook(histogramHook);
    std::vector<char> slice(static_cast<size_t>(info.dims.x * info.dims.y) * valueSize(info.type));
    for (int64_t z = 0; z < info.dims.z; ++z) only.readSlices(1, slice.data());
  }

  meta.histogram = histogram.finish();
  const uint64_t bricksSize = bricks.size();
  bricks.close();
  writeIndex(tmp / "index.bin", levels, B, info.type, bricksSize);
  meta.bytesStored = int64_t(bricksSize) + int64_t(fs::file_size(tmp / "index.bin"));
  for (const LevelBuild& l : levels) meta.levels.push_back({l.dims, l.bricks, l.bricksStored, l.bytesStored});
  {
    OutputFile json(tmp / "store.json");
    const std::string text = meta.toJson();
    json.append(text.data(), text.size());
    json.close();
  }
  syncDirectory(tmp);

  // Into place: an existing store is moved aside first and removed only once the new one is there.
  const fs::path old = parent / ("." + output.filename().string() + ".old-" + std::to_string(::getpid()));
  const bool replacing = fs::exists(output, ec);
  if (replacing) {
    fs::rename(output, old, ec);
    if (ec) throw IoError("cannot move aside " + output.string() + ": " + ec.message());
  }
  fs::rename(tmp, output, ec);
  if (ec) {
    std::error_code ignore;
    if (replacing) fs::rename(old, output, ignore);
    throw IoError("cannot rename " + tmp.string() + " to " + output.string() + ": " + ec.message());
  }
  guard.release();
  if (replacing) fs::remove_all(old, ec);
  syncDirectory(parent);

  PrepSummary summary;
  summary.meta = std::move(meta);
  summary.bytesIn = state.bytesIn;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary.peakRssBytes = peakRssBytes();
  return summary;
}

}  // namespace voxbrick::store
