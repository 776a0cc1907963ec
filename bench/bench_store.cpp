// Brick-store benchmark: prep throughput and brick fetch throughput (cold and warm), beside a plain sequential
// read of the same raw bytes, on a synthetic 512^3 volume and the real MRI. Writes CSV and a markdown table.
//
//   bench_store --work DIR --out bench/results/store [--size 512] [--repeats 3]
//   bench_store --make-raw FILE --spec SYNTHETIC_SPEC      (writes a synthetic field as a raw f32 file)
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "brickstore/ingest/Sources.h"
#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"
#include "brickstore/source/VolumeSource.h"

namespace fs = std::filesystem;
using namespace voxbrick::store;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

/// Drops a file's pages from the OS cache so the next read comes from the disk.
void dropPageCache(const fs::path& file) {
  int fd = ::open(file.c_str(), O_RDONLY);
  if (fd < 0) return;
  ::fdatasync(fd);
  ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
  ::close(fd);
}

/// Streams a source into a raw file (the same bytes every path below reads).
void writeRaw(VolumeSource& src, const fs::path& path) {
  const VolumeInfo& info = src.info();
  const size_t slice = size_t(info.dims.x * info.dims.y) * valueSize(info.type);
  std::vector<char> buf(slice);
  std::ofstream out(path, std::ios::binary);
  for (int64_t z = 0; z < info.dims.z; ++z) {
    src.readSlices(1, buf.data());
    out.write(buf.data(), std::streamsize(slice));
  }
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

/// Seconds to read a file sequentially with read() in 4 MiB chunks.
double sequentialRead(const fs::path& path, bool cold) {
  if (cold) dropPageCache(path);
  int fd = ::open(path.c_str(), O_RDONLY);
  std::vector<char> buf(4 << 20);
  auto t = Clock::now();
  volatile char sink = 0;
  ssize_t n;
  while ((n = ::read(fd, buf.data(), buf.size())) > 0) sink = sink + buf[size_t(n) - 1];
  double s = since(t);
  ::close(fd);
  return s;
}

struct Row {
  std::string dataset, measure, unit;
  double value;
  std::string note;
};

struct Options {
  std::string work = "bench/work", out = "bench/results/store", makeRaw, spec;
  int size = 512, repeats = 3;
};

/// Median seconds of sequential reads of `raw` from the page cache and from disk, as rows.
void sequentialRows(const std::string& name, const fs::path& raw, double rawBytes, int repeats,
                    std::vector<Row>& rows) {
  std::vector<double> seqWarm, seqCold;
  for (int r = 0; r < repeats; ++r) {
    seqCold.push_back(sequentialRead(raw, true));
    seqWarm.push_back(sequentialRead(raw, false));
  }
  rows.push_back({name, "sequential read, page cache", "GB/s", rawBytes / median(seqWarm) / 1e9, "read() 4 MiB"});
  rows.push_back({name, "sequential read, from disk", "GB/s", rawBytes / median(seqCold) / 1e9, "after DONTNEED"});
}

/// Prep of the raw file into a store: input MB/s, the median of `repeats`.
double prepRate(const fs::path& raw, const SourceOptions& so, const fs::path& storePath, int level, bool vdb,
                int repeats) {
  std::vector<double> secs;
  for (int r = 0; r < repeats; ++r) {
    auto src = openSource(raw.string(), so);
    PrepOptions po;
    po.zstdLevel = level;
    po.writeVdb = vdb;
    po.overwrite = true;
    auto t = Clock::now();
    prepStore(*src, storePath, po);
    secs.push_back(since(t));
  }
  return double(fs::file_size(raw)) / median(secs) / 1e6;
}

/// The level-0 bricks a store holds.
std::vector<BrickKey> storedBricks(const BrickStore& store) {
  std::vector<BrickKey> keys;
  const LevelMeta& l0 = store.level(0);
  for (uint32_t k = 0; k < l0.bricks.z; ++k)
    for (uint32_t j = 0; j < l0.bricks.y; ++j)
      for (uint32_t i = 0; i < l0.bricks.x; ++i)
        if (store.isStored({0, i, j, k})) keys.push_back({0, i, j, k});
  return keys;
}

/// Seconds per pass over every brick: decoding alone, and fetching through a cold cache (page cache, then disk) and
/// a warm one.
struct FetchTimes {
  std::vector<double> decode, cold, coldDisk, warm;
};

FetchTimes timeFetches(const std::shared_ptr<const BrickStore>& store, const std::vector<BrickKey>& keys,
                       const fs::path& storePath, int repeats) {
  const double decodedBytes = double(keys.size()) * double(store->brickBytes());
  std::vector<char> dst(store->brickBytes());
  FetchTimes times;
  for (int r = 0; r < repeats; ++r) {
    auto t = Clock::now();
    for (const BrickKey& key : keys) store->readBrick(key, dst.data());
    times.decode.push_back(since(t));
    for (bool fromDisk : {false, true}) {
      if (fromDisk) dropPageCache(storePath / "bricks.bin");
      BrickCache cache(store, size_t(decodedBytes) + (64 << 20), 0);
      t = Clock::now();
      for (const BrickKey& key : keys) std::memcpy(dst.data(), cache.get(key)->data(), dst.size());
      (fromDisk ? times.coldDisk : times.cold).push_back(since(t));
      if (!fromDisk) {
        t = Clock::now();
        for (const BrickKey& key : keys) std::memcpy(dst.data(), cache.get(key)->data(), dst.size());
        times.warm.push_back(since(t));
      }
    }
  }
  return times;
}

/// One zstd level: prep without the grid, then decode and fetch throughput and the stored size. The level trades
/// stored size against decode speed.
void zstdLevelRows(const std::string& name, const fs::path& raw, const SourceOptions& so, const fs::path& storePath,
                   int level, int repeats, std::vector<Row>& rows) {
  const double rawBytes = double(fs::file_size(raw));
  const std::string tag = "zstd " + std::to_string(level) + ": ";
  rows.push_back({name, tag + "prep, bricks only", "MB/s in", prepRate(raw, so, storePath, level, false, repeats),
                  "B=32, all cores"});
  auto store = BrickStore::open(storePath);
  const std::vector<BrickKey> keys = storedBricks(*store);
  const double decodedBytes = double(keys.size()) * double(store->brickBytes());
  const FetchTimes t = timeFetches(store, keys, storePath, repeats);
  const double n = double(keys.size());
  auto perSecond = [&](const std::vector<double>& v) { return std::to_string(size_t(n / median(v))) + " bricks/s"; };
  rows.push_back({name, tag + "decode only, 1 core", "GB/s", decodedBytes / median(t.decode) / 1e9,
                  perSecond(t.decode) + "; readBrick into a reused buffer"});
  rows.push_back({name, tag + "fetch cold, 1 core", "GB/s", decodedBytes / median(t.cold) / 1e9,
                  perSecond(t.cold) + "; BrickCache miss (decode + new buffer); frames in page cache"});
  rows.push_back({name, tag + "fetch cold, from disk", "GB/s", decodedBytes / median(t.coldDisk) / 1e9,
                  perSecond(t.coldDisk) + "; as above after POSIX_FADV_DONTNEED"});
  rows.push_back({name, tag + "fetch warm", "GB/s", decodedBytes / median(t.warm) / 1e9,
                  perSecond(t.warm) + "; BrickCache hit + memcpy of the brick"});
  rows.push_back({name, tag + "stored / raw", "ratio", double(store->meta().bytesStored) / rawBytes,
                  std::to_string(keys.size()) + " of " + std::to_string(store->level(0).bricksTotal()) +
                      " level-0 bricks stored; all levels"});
}

std::vector<Row> benchDataset(const std::string& name, const std::string& input, const fs::path& work, int repeats) {
  std::vector<Row> rows;
  const fs::path raw = work / (name + ".raw");
  VolumeInfo info;
  {
    auto src = openSource(input, {});
    info = src->info();
    writeRaw(*src, raw);
  }
  const double rawBytes = double(fs::file_size(raw));
  std::printf("%s: %lldx%lldx%lld %s, %.1f MB raw\n", name.c_str(), (long long)info.dims.x, (long long)info.dims.y,
              (long long)info.dims.z, std::string(valueTypeName(info.type)).c_str(), rawBytes / 1e6);
  sequentialRows(name, raw, rawBytes, repeats, rows);

  SourceOptions so;
  so.dims = info.dims;
  so.type = std::string(valueTypeName(info.type));
  so.spacing = info.spacing;
  so.spacingGiven = true;
  const fs::path storePath = work / (name + ".vbs");
  const int defaultLevel = PrepOptions{}.zstdLevel;
  rows.push_back({name, "prep, with OpenVDB grid", "MB/s in", prepRate(raw, so, storePath, defaultLevel, true, repeats),
                  "B=32, zstd " + std::to_string(defaultLevel) + ", all cores"});
  for (int level : {-1, 1, 3}) zstdLevelRows(name, raw, so, storePath, level, repeats, rows);
  fs::remove(raw);
  return rows;
}

void addOptions(CLI::App& app, Options& o) {
  app.add_option("--work", o.work, "directory for the raw files and stores")->capture_default_str();
  app.add_option("--out", o.out, "directory for store.csv and store.md")->capture_default_str();
  app.add_option("--size", o.size, "side of the synthetic volume")->capture_default_str();
  app.add_option("--repeats", o.repeats, "repeats of each measure (the median is reported)")->capture_default_str();
  app.add_option("--make-raw", o.makeRaw, "only write the synthetic field --spec as a raw f32 file here");
  app.add_option("--spec", o.spec, "with --make-raw: a synthetic spec (blobs,n=512)");
}

/// `--make-raw FILE --spec SPEC`: the synthetic field as a raw f32 file.
void makeRaw(const Options& o) {
  auto src = openSource("synthetic:" + o.spec, {});
  writeRaw(*src, o.makeRaw);
  const Vec3i d = src->info().dims;
  std::printf("%s: %lld,%lld,%lld f32\n", o.makeRaw.c_str(), (long long)d.x, (long long)d.y, (long long)d.z);
}

void writeRows(const fs::path& out, const std::vector<Row>& rows) {
  std::ofstream csv(out / "store.csv");
  csv << "dataset,measure,value,unit,note\n";
  std::ofstream md(out / "store.md");
  md << "| dataset | measure | value | unit | note |\n|---|---|---:|---|---|\n";
  for (const Row& r : rows) {
    char v[32];
    std::snprintf(v, sizeof v, "%.3f", r.value);
    csv << r.dataset << ',' << r.measure << ',' << v << ',' << r.unit << ",\"" << r.note << "\"\n";
    md << "| " << r.dataset << " | " << r.measure << " | " << v << " | " << r.unit << " | " << r.note << " |\n";
    std::printf("%-16s %-34s %10s %-8s %s\n", r.dataset.c_str(), r.measure.c_str(), v, r.unit.c_str(), r.note.c_str());
  }
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"bench_store: prep and brick fetch throughput beside a plain sequential read"};
  addOptions(app, o);
  CLI11_PARSE(app, argc, argv);
  if (!o.makeRaw.empty()) {
    makeRaw(o);
    return 0;
  }
  const fs::path work = o.work;
  fs::create_directories(work);
  fs::create_directories(o.out);
  std::vector<Row> rows;
  const std::string n = std::to_string(o.size);
  for (auto& r : benchDataset("blobs-" + n, "synthetic:blobs,n=" + n, work, o.repeats)) rows.push_back(r);
  for (auto& r : benchDataset("mri-ch2better", "/usr/share/mricron/templates/ch2better.nii.gz", work, o.repeats))
    rows.push_back(r);
  writeRows(o.out, rows);
  return 0;
}
