// zstd frames for bricks. Contexts are thread-local: creating one per brick costs more than decoding a sparse brick.
#include "brickstore/Codec.h"

#include <zstd.h>

#include <memory>

#include "brickstore/Errors.h"

namespace voxbrick::store {
namespace {

struct CCtxDeleter { void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); } };
struct DCtxDeleter { void operator()(ZSTD_DCtx* c) const { ZSTD_freeDCtx(c); } };

ZSTD_CCtx* threadCCtx() {
  thread_local std::unique_ptr<ZSTD_CCtx, CCtxDeleter> ctx(ZSTD_createCCtx());
  return ctx.get();
}
ZSTD_DCtx* threadDCtx() {
  thread_local std::unique_ptr<ZSTD_DCtx, DCtxDeleter> ctx(ZSTD_createDCtx());
  return ctx.get();
}

}  // namespace

void compressFrame(const void* src, size_t size, int level, std::vector<char>& dst) {
  ZSTD_CCtx* cctx = threadCCtx();
  ZSTD_CCtx_reset(cctx, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, level);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 1);
  dst.resize(ZSTD_compressBound(size));
  size_t n = ZSTD_compress2(cctx, dst.data(), dst.size(), src, size);
  if (ZSTD_isError(n)) throw StoreError(std::string("compressFrame: zstd: ") + ZSTD_getErrorName(n));
  dst.resize(n);
}

void decompressFrame(const void* src, size_t size, void* dst, size_t expectedSize, const std::string& what) {
  unsigned long long content = ZSTD_getFrameContentSize(src, size);
  if (content == ZSTD_CONTENTSIZE_ERROR)
    throw CorruptStoreError(what + ": not a zstd frame");
  if (content != ZSTD_CONTENTSIZE_UNKNOWN && content != expectedSize)
    throw CorruptStoreError(what + ": frame holds " + std::to_string(content) + " bytes, expected " +
                            std::to_string(expectedSize));
  size_t n = ZSTD_decompressDCtx(threadDCtx(), dst, expectedSize, src, size);
  if (ZSTD_isError(n)) throw CorruptStoreError(what + ": corrupt zstd frame (" + ZSTD_getErrorName(n) + ")");
  if (n != expectedSize)
    throw CorruptStoreError(what + ": decoded " + std::to_string(n) + " bytes, expected " +
                            std::to_string(expectedSize));
}

}  // namespace voxbrick::store
