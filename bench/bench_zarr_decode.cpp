// Chunk decoding of an OME-Zarr: voxbrick's decode (decodeZarrChunk: the checks, then the codec) against the codec
// library called directly on the same bytes (the codec's own speed), both into a ready buffer, and the whole level cut
// into slabs through ZarrChunks (file reads, decode, conversion), all on one thread. bench/run_zarr.sh runs it.
//
//   bench_zarr_decode ZARR [--level 0] [--repeats 3]   prints one CSV row (header with --header)
#include <blosc.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "brickstore/format/Convert.h"
#include "brickstore/zarr/ZarrChunks.h"

namespace {

using namespace voxbrick::store;
using Clock = std::chrono::steady_clock;

template <class F>
double bestSeconds(int repeats, F&& f) {
  double best = 1e30;
  for (int i = 0; i < repeats; ++i) {
    const auto start = Clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
  }
  return best;
}

std::vector<unsigned char> readAll(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The codec library alone, into `out` (already sized).
void libraryDecode(const ZarrArrayMeta& a, const std::vector<unsigned char>& in, std::vector<unsigned char>& out) {
  switch (a.compressor) {
    case ZarrCompressor::None: std::copy(in.begin(), in.end(), out.begin()); return;
    case ZarrCompressor::Blosc: blosc_decompress_ctx(in.data(), out.data(), out.size(), 1); return;
    case ZarrCompressor::Zstd: ZSTD_decompress(out.data(), out.size(), in.data(), in.size()); return;
    case ZarrCompressor::Zlib:
    case ZarrCompressor::Gzip: {
      z_stream z{};
      inflateInit2(&z, a.compressor == ZarrCompressor::Gzip ? 31 : 15);
      z.next_in = const_cast<unsigned char*>(in.data());
      z.avail_in = uInt(in.size());
      z.next_out = out.data();
      z.avail_out = uInt(out.size());
      inflate(&z, Z_FINISH);
      inflateEnd(&z);
      return;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"OME-Zarr chunk decode speed"};
  std::string zarr;
  int level = 0, repeats = 3;
  bool header = false;
  app.add_option("zarr", zarr, "OME-Zarr directory")->required();
  app.add_option("--level", level, "pyramid level (dataset index)");
  app.add_option("--repeats", repeats, "best of this many runs");
  app.add_flag("--header", header, "print the CSV header first");
  CLI11_PARSE(app, argc, argv);

  ZarrMeta meta = readZarrMeta(zarr, {});
  const ZarrArrayMeta a = meta.levels.at(size_t(level));
  std::vector<std::vector<unsigned char>> files;
  int64_t compressed = 0;
  const std::vector<int64_t> fixed = meta.fixedChunkIndex();
  for (int64_t z = 0; z < a.chunkGrid.z; ++z)
    for (int64_t y = 0; y < a.chunkGrid.y; ++y)
      for (int64_t x = 0; x < a.chunkGrid.x; ++x) {
        const auto file = a.chunkFile({x, y, z}, fixed);
        if (!std::filesystem::exists(file)) continue;
        files.push_back(readAll(file));
        compressed += int64_t(files.back().size());
      }
  const double decoded = double(files.size()) * double(a.chunkBytes());
  // Interleaved, best of `repeats` each, so that neither gains from running second on a loaded machine.
  std::vector<unsigned char> out(size_t(a.chunkBytes()));
  double ours = 1e30, library = 1e30;
  for (int r = 0; r < repeats; ++r) {
    ours = std::min(ours, bestSeconds(1, [&] {
                      for (const auto& f : files) decodeZarrChunk(a, f, "chunk", out.data());
                    }));
    library = std::min(library, bestSeconds(1, [&] {
                         for (const auto& f : files) libraryDecode(a, f, out);
                       }));
  }
  // The whole level in slabs of one chunk row, as prep reads it (a fresh cache each run: every chunk decoded once).
  const int64_t slab = a.chunkDims.z;
  const double region = bestSeconds(repeats, [&] {
    ZarrChunks chunks(meta, size_t(a.chunkGrid.x * a.chunkGrid.y * a.chunkBytes()) + (size_t(64) << 20));
    std::vector<unsigned char> buf(size_t(a.dims.x * a.dims.y * slab) * valueSize(chunks.type()));
    for (int64_t z0 = 0; z0 < a.dims.z; z0 += slab)
      chunks.readRegion(level, {0, 0, z0}, {a.dims.x - 1, a.dims.y - 1, std::min(z0 + slab, a.dims.z) - 1}, buf.data());
  });
  const double levelBytes = double(a.dims.volume()) * double(fileValueSize(a.fileType));
  if (header)
    std::printf(
        "codec,dims,chunk,chunks,compressed_mb,decoded_mb,voxbrick_decode_mbps,library_decode_mbps,"
        "level_read_mbps\n");
  std::printf("%s,%lldx%lldx%lld,%lld,%zu,%.1f,%.1f,%.0f,%.0f,%.0f\n", a.compressorText.c_str(), (long long)a.dims.x,
              (long long)a.dims.y, (long long)a.dims.z, (long long)a.chunkDims.x, files.size(), compressed / 1048576.0,
              decoded / 1048576.0, decoded / 1048576.0 / ours, decoded / 1048576.0 / library,
              levelBytes / 1048576.0 / region);
  return 0;
}
