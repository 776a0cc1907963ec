// zstd frames for bricks. Contexts are thread-local: creating one per brick costs more than decoding a sparse brick.
#include "brickstore/format/Codec.h"

#define ZSTD_STATIC_LINKING_ONLY  // ZSTD_c_literalCompressionMode
#include <zstd.h>

#include <memory>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

struct CCtxDeleter {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxDeleter {
  void operator()(ZSTD_DCtx* c) const { ZSTD_freeDCtx(c); }
};

ZSTD_CCtx* threadCCtx() {
  thread_local std::unique_ptr<ZSTD_CCtx, CCtxDeleter> ctx(ZSTD_createCCtx());
  return ctx.get();
}
ZSTD_DCtx* threadDCtx() {
  thread_local std::unique_ptr<ZSTD_DCtx, DCtxDeleter> ctx(ZSTD_createDCtx());
  return ctx.get();
}

/// Byte planes: out[b * count + n] = in[n * E + b]. E is a template parameter so that the loops unroll and
/// vectorise: the unshuffle runs on every decode.
template <size_t E>
void shuffleT(const char* in, char* out, size_t count) {
  for (size_t n = 0; n < count; ++n)
    for (size_t b = 0; b < E; ++b) out[b * count + n] = in[n * E + b];
}

template <size_t E>
void unshuffleT(const char* in, char* out, size_t count) {
  for (size_t n = 0; n < count; ++n)
    for (size_t b = 0; b < E; ++b) out[n * E + b] = in[b * count + n];
}

void shuffle(const char* in, char* out, size_t count, size_t elementSize) {
  if (elementSize == 2) return shuffleT<2>(in, out, count);
  return shuffleT<4>(in, out, count);
}

void unshuffle(const char* in, char* out, size_t count, size_t elementSize) {
  if (elementSize == 2) return unshuffleT<2>(in, out, count);
  return unshuffleT<4>(in, out, count);
}

std::vector<char>& threadScratch(size_t size) {
  thread_local std::vector<char> scratch;
  scratch.resize(size);
  return scratch;
}

}  // namespace

void compressFrame(const void* src, size_t size, size_t elementSize, int level, std::vector<char>& dst) {
  if (elementSize > 1) {
    std::vector<char>& planes = threadScratch(size);
    shuffle(static_cast<const char*>(src), planes.data(), size / elementSize, elementSize);
    src = planes.data();
  }
  ZSTD_CCtx* cctx = threadCCtx();
  ZSTD_CCtx_reset(cctx, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, level);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 1);
  // 32-bit values at the default level store their literals as they are, as zstd's own negative levels do: on float
  // bricks (planes of mantissa noise) Huffman coding them costs a third of the compression time for 0.3 % of the
  // bytes. Not for 8- and 16-bit values, where it saves a quarter of the bytes of an MRI.
  if (level == 1 && elementSize == 4) ZSTD_CCtx_setParameter(cctx, ZSTD_c_literalCompressionMode, ZSTD_ps_disable);
  dst.resize(ZSTD_compressBound(size));
  size_t n = ZSTD_compress2(cctx, dst.data(), dst.size(), src, size);
  if (ZSTD_isError(n)) throw StoreError(std::string("compressFrame: zstd: ") + ZSTD_getErrorName(n));
  dst.resize(n);
}

void decompressFrame(const void* src, size_t size, size_t elementSize, void* dst, size_t expectedSize,
                     const std::string& what) {
  unsigned long long content = ZSTD_getFrameContentSize(src, size);
  if (content == ZSTD_CONTENTSIZE_ERROR) throw CorruptStoreError(what + ": not a zstd frame");
  if (content != ZSTD_CONTENTSIZE_UNKNOWN && content != expectedSize)
    throw CorruptStoreError(what + ": frame holds " + std::to_string(content) + " bytes, expected " +
                            std::to_string(expectedSize));
  void* target = elementSize > 1 ? threadScratch(expectedSize).data() : dst;
  size_t n = ZSTD_decompressDCtx(threadDCtx(), target, expectedSize, src, size);
  if (ZSTD_isError(n)) throw CorruptStoreError(what + ": corrupt zstd frame (" + ZSTD_getErrorName(n) + ")");
  if (n != expectedSize)
    throw CorruptStoreError(what + ": decoded " + std::to_string(n) + " bytes, expected " +
                            std::to_string(expectedSize));
  if (elementSize > 1)
    unshuffle(static_cast<const char*>(target), static_cast<char*>(dst), expectedSize / elementSize, elementSize);
}

}  // namespace voxbrick::store
