// Shuffled zstd frames. Contexts are thread-local: creating one per block costs more than decoding a sparse brick.
#include "common/BlockCodec.h"

#define ZSTD_STATIC_LINKING_ONLY  // ZSTD_c_literalCompressionMode
#include <zstd.h>

#include <memory>

namespace voxbrick::common {
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

/// Blocks up to this size are shuffled through a buffer each thread keeps (a brick's are, (256 + 2)^3 floats at
/// most); a larger one (a mesh's points) through `own`, so that no thread keeps its size afterwards.
constexpr size_t kKeptScratchBytes = size_t{80} << 20;

std::vector<char>& scratch(size_t size, std::vector<char>& own) {
  thread_local std::vector<char> kept;
  std::vector<char>& buffer = size <= kKeptScratchBytes ? kept : own;
  buffer.resize(size);
  return buffer;
}

}  // namespace

void encodeBlock(const void* src, size_t size, const BlockEncoding& encoding, std::vector<char>& dst) {
  std::vector<char> own;
  if (encoding.elementSize > 1) {
    std::vector<char>& planes = scratch(size, own);
    shuffle(static_cast<const char*>(src), planes.data(), size / encoding.elementSize, encoding.elementSize);
    src = planes.data();
  }
  ZSTD_CCtx* cctx = threadCCtx();
  ZSTD_CCtx_reset(cctx, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, encoding.level);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, encoding.checksum ? 1 : 0);
  if (encoding.rawLiterals) ZSTD_CCtx_setParameter(cctx, ZSTD_c_literalCompressionMode, ZSTD_ps_disable);
  dst.resize(ZSTD_compressBound(size));
  const size_t n = ZSTD_compress2(cctx, dst.data(), dst.size(), src, size);
  if (ZSTD_isError(n)) throw CodecError(ZSTD_getErrorName(n));
  dst.resize(n);
}

BlockDecoding decodeBlock(const void* src, size_t size, size_t elementSize, void* dst, size_t expectedSize,
                          bool requireSize) {
  const unsigned long long content = ZSTD_getFrameContentSize(src, size);
  if (content == ZSTD_CONTENTSIZE_ERROR) return {BlockFault::NotAFrame, 0, {}};
  if (content == ZSTD_CONTENTSIZE_UNKNOWN) {
    if (requireSize) return {BlockFault::SizeUnknown, 0, {}};
  } else if (content != expectedSize) {
    return {BlockFault::SizeDiffers, content, {}};
  }
  std::vector<char> own;
  void* target = elementSize > 1 ? scratch(expectedSize, own).data() : dst;
  const size_t n = ZSTD_decompressDCtx(threadDCtx(), target, expectedSize, src, size);
  if (ZSTD_isError(n)) return {BlockFault::Corrupt, 0, ZSTD_getErrorName(n)};
  if (n != expectedSize) return {BlockFault::WrongLength, n, {}};
  if (elementSize > 1)
    unshuffle(static_cast<const char*>(target), static_cast<char*>(dst), expectedSize / elementSize, elementSize);
  return {};
}

}  // namespace voxbrick::common
