// Zarr chunks: which files exist, decoding (zlib, gzip and zstd through their libraries, blosc through Debian's
// libblosc), a byte-bounded LRU of decoded chunks, and boxes of voxels cut out of them in the store's type.
#include "brickstore/zarr/ZarrChunks.h"

#include "brickstore/format/Convert.h"

#include <blosc.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include "brickstore/format/BrickFile.h"
#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace fs = std::filesystem;
namespace {

void inflateAll(const std::vector<unsigned char>& in, unsigned char* out, size_t expected, bool gzip,
                const std::string& name) {
  z_stream z{};
  if (inflateInit2(&z, gzip ? 15 + 16 : 15) != Z_OK) throw CorruptStoreError(name + ": zlib cannot start");
  z.next_in = const_cast<unsigned char*>(in.data());
  z.avail_in = uInt(in.size());
  z.next_out = out;
  z.avail_out = uInt(expected);
  const int rc = inflate(&z, Z_FINISH);
  const size_t produced = z.total_out;
  inflateEnd(&z);
  if (rc != Z_STREAM_END || produced != expected)
    throw CorruptStoreError(name + ": " + (gzip ? "gzip" : "zlib") + " stream is truncated or corrupt (" +
                            (rc == Z_STREAM_END
                                 ? std::to_string(produced) + " bytes decoded, expected " + std::to_string(expected)
                                 : std::string(z.msg ? z.msg : "ends early")) +
                            ")");
}

void zstdAll(const std::vector<unsigned char>& in, unsigned char* out, size_t expected, const std::string& name) {
  const size_t n = ZSTD_decompress(out, expected, in.data(), in.size());
  if (ZSTD_isError(n))
    throw CorruptStoreError(name + ": zstd frame is truncated or corrupt (" + ZSTD_getErrorName(n) + ")");
  if (n != expected)
    throw CorruptStoreError(name + ": zstd frame holds " + std::to_string(n) + " bytes, expected " +
                            std::to_string(expected));
}

void bloscAll(const std::vector<unsigned char>& in, unsigned char* out, size_t expected, const std::string& name) {
  size_t nbytes = 0;
  if (in.size() < BLOSC_MIN_HEADER_LENGTH || blosc_cbuffer_validate(in.data(), in.size(), &nbytes) != 0)
    throw CorruptStoreError(name + ": blosc header is truncated or corrupt (" + std::to_string(in.size()) + " bytes)");
  size_t cbytes = 0, blocksize = 0;
  blosc_cbuffer_sizes(in.data(), &nbytes, &cbytes, &blocksize);
  if (nbytes != expected)
    throw CorruptStoreError(name + ": blosc frame holds " + std::to_string(nbytes) + " bytes, expected " +
                            std::to_string(expected));
  if (cbytes != in.size())
    throw CorruptStoreError(name + ": blosc frame says " + std::to_string(cbytes) + " bytes, the file has " +
                            std::to_string(in.size()) + " (truncated)");
  const int n = blosc_decompress_ctx(in.data(), out, expected, 1);
  if (n < 0 || size_t(n) != expected)
    throw CorruptStoreError(name + ": blosc frame is corrupt (decoder returned " + std::to_string(n) + ")");
}

std::vector<unsigned char> readWhole(const fs::path& file, int64_t limit) {
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) throw IoError(errnoMessage("cannot open " + file.string()));
  const std::streamoff size = in.tellg();
  if (size < 0 || size > limit)
    throw CorruptStoreError(file.string() + ": " + std::to_string(size) + " bytes, more than a chunk can hold");
  std::vector<unsigned char> bytes(static_cast<size_t>(size));
  in.seekg(0);
  in.read(reinterpret_cast<char*>(bytes.data()), size);
  if (!in) throw IoError(errnoMessage("cannot read " + file.string()));
  return bytes;
}

}  // namespace

void decodeZarrChunk(const ZarrArrayMeta& a, const std::vector<unsigned char>& file, const std::string& name,
                     unsigned char* out) {
  const size_t expected = size_t(a.chunkBytes());
  switch (a.compressor) {
    case ZarrCompressor::None:
      if (file.size() != expected)
        throw CorruptStoreError(name + ": " + std::to_string(file.size()) + " bytes, an uncompressed chunk has " +
                                std::to_string(expected) + " (truncated)");
      std::memcpy(out, file.data(), expected);
      return;
    case ZarrCompressor::Zlib: return inflateAll(file, out, expected, false, name);
    case ZarrCompressor::Gzip: return inflateAll(file, out, expected, true, name);
    case ZarrCompressor::Zstd: return zstdAll(file, out, expected, name);
    case ZarrCompressor::Blosc: return bloscAll(file, out, expected, name);
  }
  throw CorruptStoreError(name + ": unknown compressor");
}

ZarrChunks::ZarrChunks(ZarrMeta meta, size_t cacheBytes)
    : mMeta(std::move(meta)),
      mType(mMeta.storeType()),
      mBackground(mMeta.background()),
      mFixedChunk(mMeta.fixedChunkIndex()),
      mFixedIn(mMeta.fixedInChunk()),
      mCacheBytes(cacheBytes) {
  for (const ZarrArrayMeta& a : mMeta.levels) {
    const Vec3i g = a.chunkGrid;
    std::vector<uint8_t> exists(size_t(g.volume()), 0);
    std::error_code ec;
    for (int64_t z = 0; z < g.z; ++z)
      for (int64_t y = 0; y < g.y; ++y)
        for (int64_t x = 0; x < g.x; ++x)
          exists[size_t(x + g.x * (y + g.y * z))] = fs::is_regular_file(a.chunkFile({x, y, z}, mFixedChunk), ec);
    mExists.push_back(std::move(exists));
  }
}

int64_t ZarrChunks::chunksPresent(int level) const {
  const auto& e = mExists.at(size_t(level));
  return std::count(e.begin(), e.end(), uint8_t{1});
}

bool ZarrChunks::anyChunk(int level, const Vec3i& lo, const Vec3i& hi) const {
  const ZarrArrayMeta& a = mMeta.levels[size_t(level)];
  const auto& exists = mExists[size_t(level)];
  for (int64_t z = lo.z / a.chunkDims.z; z <= hi.z / a.chunkDims.z; ++z)
    for (int64_t y = lo.y / a.chunkDims.y; y <= hi.y / a.chunkDims.y; ++y)
      for (int64_t x = lo.x / a.chunkDims.x; x <= hi.x / a.chunkDims.x; ++x)
        if (exists[size_t(x + a.chunkGrid.x * (y + a.chunkGrid.y * z))]) return true;
  return false;
}

ZarrChunks::Chunk ZarrChunks::chunk(int level, const Vec3i& c) const {
  const ZarrArrayMeta& a = mMeta.levels[size_t(level)];
  const uint64_t key = (uint64_t(level) << 56) | uint64_t(c.x + a.chunkGrid.x * (c.y + a.chunkGrid.y * c.z));
  {
    std::lock_guard lock(mMutex);
    if (auto it = mIndex.find(key); it != mIndex.end()) {
      mLru.splice(mLru.begin(), mLru, it->second);
      return it->second->second;
    }
  }
  const fs::path file = a.chunkFile(c, mFixedChunk);
  const std::string name = file.string() + " (chunk " + std::to_string(c.x) + "," + std::to_string(c.y) + "," +
                           std::to_string(c.z) + " of level " + a.path + ")";
  auto decoded = std::make_shared<DecodedChunk>();
  decoded->size = size_t(a.chunkBytes());
  decoded->bytes = std::make_unique_for_overwrite<unsigned char[]>(decoded->size);
  decodeZarrChunk(a, readWhole(file, kMaxZarrChunkBytes + (int64_t{1} << 20)), name, decoded->bytes.get());
  Chunk data = std::move(decoded);
  mDecoded.fetch_add(1, std::memory_order_relaxed);
  std::lock_guard lock(mMutex);
  if (mIndex.count(key)) return data;
  mLru.emplace_front(key, data);
  mIndex[key] = mLru.begin();
  mHeld += data->size;
  while (mHeld > mCacheBytes && mLru.size() > 1) {
    mHeld -= mLru.back().second->size;
    mIndex.erase(mLru.back().first);
    mLru.pop_back();
  }
  return data;
}

void ZarrChunks::copyFromChunk(int level, const Vec3i& c, const Chunk& data, const Vec3i& lo, const Vec3i& hi,
                               const Vec3i& rlo, const Vec3i& rhi, unsigned char* dst) const {
  const ZarrArrayMeta& a = mMeta.levels[size_t(level)];
  const size_t rank = a.chunks.size(), s = rank - 3, in = fileValueSize(a.fileType), out = valueSize(mType);
  // Element strides of the chunk, per axis, in C or F order.
  std::vector<int64_t> stride(rank, 1);
  if (a.fortranOrder)
    for (size_t d = 1; d < rank; ++d) stride[d] = stride[d - 1] * a.chunks[d - 1];
  else
    for (size_t d = rank - 1; d-- > 0;) stride[d] = stride[d + 1] * a.chunks[d + 1];
  int64_t base = 0;
  for (size_t d = 0; d < s; ++d) base += mFixedIn[d] * stride[d];
  const int64_t sx = stride[s + 2], sy = stride[s + 1], sz = stride[s];
  const Vec3i origin{c.x * a.chunkDims.x, c.y * a.chunkDims.y, c.z * a.chunkDims.z};
  Conversion conv;
  conv.from = a.fileType;
  conv.swapBytes = in > 1 && needsSwap(a.bigEndian);
  const int64_t run = rhi.x - rlo.x + 1, wx = hi.x - lo.x + 1, wy = hi.y - lo.y + 1;
  std::vector<unsigned char> gathered(sx == 1 ? 0 : size_t(run) * in);
  for (int64_t z = rlo.z; z <= rhi.z; ++z)
    for (int64_t y = rlo.y; y <= rhi.y; ++y) {
      const int64_t e0 = base + (rlo.x - origin.x) * sx + (y - origin.y) * sy + (z - origin.z) * sz;
      const unsigned char* src = data->bytes.get() + size_t(e0) * in;
      if (sx != 1) {
        for (int64_t x = 0; x < run; ++x) std::memcpy(&gathered[size_t(x) * in], src + size_t(x * sx) * in, in);
        src = gathered.data();
      }
      unsigned char* o = dst + size_t((rlo.x - lo.x) + wx * ((y - lo.y) + wy * (z - lo.z))) * out;
      conv.apply(src, o, size_t(run));
      if (mType == ValueType::F32) {
        float* f = reinterpret_cast<float*>(o);
        for (int64_t x = 0; x < run; ++x)
          if (!std::isfinite(f[x])) f[x] = float(mBackground);
      }
    }
}

void ZarrChunks::readRegion(int level, const Vec3i& lo, const Vec3i& hi, void* dstVoid) const {
  const ZarrArrayMeta& a = mMeta.levels.at(size_t(level));
  auto* dst = static_cast<unsigned char*>(dstVoid);
  const size_t out = valueSize(mType);
  const int64_t wx = hi.x - lo.x + 1, wy = hi.y - lo.y + 1;
  const auto& exists = mExists[size_t(level)];
  for (int64_t cz = lo.z / a.chunkDims.z; cz <= hi.z / a.chunkDims.z; ++cz)
    for (int64_t cy = lo.y / a.chunkDims.y; cy <= hi.y / a.chunkDims.y; ++cy)
      for (int64_t cx = lo.x / a.chunkDims.x; cx <= hi.x / a.chunkDims.x; ++cx) {
        const Vec3i c{cx, cy, cz};
        Vec3i rlo, rhi;
        for (int d = 0; d < 3; ++d) {
          rlo[d] = std::max(lo[d], c[d] * a.chunkDims[d]);
          rhi[d] = std::min(hi[d], c[d] * a.chunkDims[d] + a.chunkDims[d] - 1);
        }
        if (!exists[size_t(cx + a.chunkGrid.x * (cy + a.chunkGrid.y * cz))]) {
          for (int64_t z = rlo.z; z <= rhi.z; ++z)
            for (int64_t y = rlo.y; y <= rhi.y; ++y)
              fillValue(mType, mBackground, dst + size_t((rlo.x - lo.x) + wx * ((y - lo.y) + wy * (z - lo.z))) * out,
                        size_t(rhi.x - rlo.x + 1));
          continue;
        }
        copyFromChunk(level, c, chunk(level, c), lo, hi, rlo, rhi, dst);
      }
}

}  // namespace voxbrick::store
