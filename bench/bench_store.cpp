// Brick-store benchmark: prep throughput and brick fetch throughput (cold and warm), beside a plain sequential
// read of the same raw bytes, on a synthetic 512^3 volume and the real MRI. Writes CSV and a markdown table.
//
//   bench_store --work DIR --out bench/results [--size 512] [--repeats 3]
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

#include "brickstore/BrickCache.h"
#include "brickstore/BrickStore.h"
#include "brickstore/StoreWriter.h"
#include "brickstore/VolumeSource.h"

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

  std::vector<double> seqWarm, seqCold;
  for (int r = 0; r < repeats; ++r) {
    seqCold.push_back(sequentialRead(raw, true));
    seqWarm.push_back(sequentialRead(raw, false));
  }
  rows.push_back({name, "sequential read, page cache", "GB/s", rawBytes / median(seqWarm) / 1e9, "read() 4 MiB"});
  rows.push_back({name, "sequential read, from disk", "GB/s", rawBytes / median(seqCold) / 1e9, "after DONTNEED"});

  SourceOptions so;
  so.dims = info.dims;
  so.type = std::string(valueTypeName(info.type));
  so.spacing = info.spacing;
  so.spacingGiven = true;
  const fs::path storePath = work / (name + ".vbs");
  auto prep = [&](int level, bool vdb) {
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
    return rawBytes / median(secs) / 1e6;
  };
  const int defaultLevel = PrepOptions{}.zstdLevel;
  rows.push_back({name, "prep, with OpenVDB grid", "MB/s in", prep(defaultLevel, true),
                  "B=32, zstd " + std::to_string(defaultLevel) + ", all cores"});

  // The zstd level trades stored size against decode speed: measure both for each candidate level.
  for (int level : {-1, 1, 3}) {
    const std::string tag = "zstd " + std::to_string(level) + ": ";
    rows.push_back({name, tag + "prep, bricks only", "MB/s in", prep(level, false), "B=32, all cores"});
    auto store = BrickStore::open(storePath);
    std::vector<BrickKey> keys;
    const LevelMeta& l0 = store->level(0);
    for (uint32_t k = 0; k < l0.bricks.z; ++k)
      for (uint32_t j = 0; j < l0.bricks.y; ++j)
        for (uint32_t i = 0; i < l0.bricks.x; ++i)
          if (store->isStored({0, i, j, k})) keys.push_back({0, i, j, k});
    const double decodedBytes = double(keys.size()) * double(store->brickBytes());
    std::vector<char> dst(store->brickBytes());
    std::vector<double> decode, cold, coldDisk, warm;
    for (int r = 0; r < repeats; ++r) {
      auto t = Clock::now();
      for (const BrickKey& key : keys) store->readBrick(key, dst.data());
      decode.push_back(since(t));
      for (bool fromDisk : {false, true}) {
        if (fromDisk) dropPageCache(storePath / "bricks.bin");
        BrickCache cache(store, size_t(decodedBytes) + (64 << 20), 0);
        t = Clock::now();
        for (const BrickKey& key : keys) std::memcpy(dst.data(), cache.get(key)->data(), dst.size());
        (fromDisk ? coldDisk : cold).push_back(since(t));
        if (!fromDisk) {
          t = Clock::now();
          for (const BrickKey& key : keys) std::memcpy(dst.data(), cache.get(key)->data(), dst.size());
          warm.push_back(since(t));
        }
      }
    }
    const double n = double(keys.size());
    auto perSecond = [&](const std::vector<double>& v) { return std::to_string(size_t(n / median(v))) + " bricks/s"; };
    rows.push_back({name, tag + "decode only, 1 core", "GB/s", decodedBytes / median(decode) / 1e9,
                    perSecond(decode) + "; readBrick into a reused buffer"});
    rows.push_back({name, tag + "fetch cold, 1 core", "GB/s", decodedBytes / median(cold) / 1e9,
                    perSecond(cold) + "; BrickCache miss (decode + new buffer); frames in page cache"});
    rows.push_back({name, tag + "fetch cold, from disk", "GB/s", decodedBytes / median(coldDisk) / 1e9,
                    perSecond(coldDisk) + "; as above after POSIX_FADV_DONTNEED"});
    rows.push_back({name, tag + "fetch warm", "GB/s", decodedBytes / median(warm) / 1e9,
                    perSecond(warm) + "; BrickCache hit + memcpy of the brick"});
    rows.push_back({name, tag + "stored / raw", "ratio", double(store->meta().bytesStored) / rawBytes,
                    std::to_string(keys.size()) + " of " + std::to_string(l0.bricksTotal()) +
                        " level-0 bricks stored; all levels"});
  }
  fs::remove(raw);
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  fs::path work = "bench/work", out = "bench/results";
  int size = 512, repeats = 3;
  std::string makeRaw, spec;
  for (int i = 1; i + 1 < argc; i += 2) {
    std::string a = argv[i];
    if (a == "--make-raw") makeRaw = argv[i + 1];
    else if (a == "--spec") spec = argv[i + 1];
    else if (a == "--work") work = argv[i + 1];
    else if (a == "--out") out = argv[i + 1];
    else if (a == "--size") size = std::stoi(argv[i + 1]);
    else if (a == "--repeats") repeats = std::stoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "bench_store: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  if (!makeRaw.empty()) {
    auto src = openSource("synthetic:" + spec, {});
    writeRaw(*src, makeRaw);
    const Vec3i d = src->info().dims;
    std::printf("%s: %lld,%lld,%lld f32\n", makeRaw.c_str(), (long long)d.x, (long long)d.y, (long long)d.z);
    return 0;
  }
  fs::create_directories(work);
  fs::create_directories(out);
  std::vector<Row> rows;
  const std::string n = std::to_string(size);
  for (auto& r : benchDataset("blobs-" + n, "synthetic:blobs,n=" + n, work, repeats)) rows.push_back(r);
  for (auto& r : benchDataset("mri-ch2better", "/usr/share/mricron/templates/ch2better.nii.gz", work, repeats))
    rows.push_back(r);

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
  return 0;
}
