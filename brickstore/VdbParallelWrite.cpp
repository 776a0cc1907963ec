// Parallel leaf-buffer writing for OpenVDB float grids: batches of leaves compressed into strings on every thread,
// appended to the stream in the tree's leaf order by a serial stage.
#include "brickstore/VdbParallelWrite.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <streambuf>
#include <string>
#include <utility>
#include <vector>

namespace voxbrick::store {
namespace {

/// An allocator whose resize leaves new chars uninitialised: leaves are copied over them at once.
template <typename T>
struct UninitialisedAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = UninitialisedAllocator<U>;
  };
  UninitialisedAllocator() = default;
  template <typename U>
  explicit UninitialisedAllocator(const UninitialisedAllocator<U>&) {}
  template <typename U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

using Bytes = std::vector<char, UninitialisedAllocator<char>>;

/// A stream buffer appending to a vector that keeps its capacity from batch to batch.
class AppendBuffer : public std::streambuf {
 public:
  Bytes bytes;

 protected:
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    bytes.insert(bytes.end(), s, s + n);
    return n;
  }
  int_type overflow(int_type c) override {
    if (!traits_type::eq_int_type(c, traits_type::eof())) bytes.push_back(traits_type::to_char_type(c));
    return traits_type::not_eof(c);
  }
};

/// The leaves of `tree` in the order Tree::writeBuffers visits them (depth first, in coordinate order, as the leaf
/// iterator does).
std::vector<const openvdb::FloatTree::LeafNodeType*> leavesInOrder(const openvdb::FloatTree& tree) {
  std::vector<const openvdb::FloatTree::LeafNodeType*> leaves;
  leaves.reserve(tree.leafCount());
  for (auto it = tree.cbeginLeaf(); it; ++it) leaves.push_back(it.getLeaf());
  return leaves;
}

using Leaf = openvdb::FloatTree::LeafNodeType;

/// Appends `leaf` to `out` as LeafNode::writeBuffers does for a stream with mask compression alone (no blosc or zip,
/// not half floats), when every inactive value equals the background, which is how prep's leaves are: the value mask,
/// metadata byte NO_MASK_OR_INACTIVE_VALS and the active values in offset order, copied straight from the leaf
/// without OpenVDB's temporary buffer and stream calls. Returns false (appending nothing) for any other leaf.
bool appendMaskCompressedLeaf(const Leaf& leaf, float background, Bytes& out) {
  constexpr size_t kWords = Leaf::NodeMaskType::WORD_COUNT;
  const Leaf::NodeMaskType& mask = leaf.getValueMask();
  const float* values = leaf.buffer().data();
  uint64_t words[kWords];
  for (size_t w = 0; w < kWords; ++w) words[w] = mask.template getWord<uint64_t>(openvdb::Index(w));
  const bool full = mask.isOn();
  if (!full)  // every inactive value must be the background (math::isExactlyEqual, as MaskCompress compares)
    for (size_t w = 0; w < kWords; ++w)
      for (uint64_t off = ~words[w]; off != 0; off &= off - 1)
        if (!(values[w * 64 + size_t(__builtin_ctzll(off))] == background)) return false;
  const size_t at = out.size();
  out.resize(at + sizeof words + 1 + Leaf::SIZE * sizeof(float));
  char* dst = out.data() + at;
  std::memcpy(dst, words, sizeof words);
  dst[sizeof words] = char(openvdb::io::NO_MASK_OR_INACTIVE_VALS);
  float* active = reinterpret_cast<float*>(dst + sizeof words + 1);
  if (full) {
    std::memcpy(active, values, Leaf::SIZE * sizeof(float));
    return true;
  }
  size_t count = 0;
  for (size_t w = 0; w < kWords; ++w)
    for (uint64_t on = words[w]; on != 0; on &= on - 1) active[count++] = values[w * 64 + size_t(__builtin_ctzll(on))];
  out.resize(at + sizeof words + 1 + count * sizeof(float));
  return true;
}

}  // namespace

bool bloscShrinksTo(const openvdb::FloatTree& tree, double ratio) {
  const auto leaves = leavesInOrder(tree);
  constexpr size_t kEvery = 16;
  const size_t samples = (leaves.size() + kEvery - 1) / kEvery;
  if (samples == 0) return true;
  const float background = tree.background();
  // Bytes each sampled leaf writes {with blosc, without}; sums of integers, so the order does not matter.
  using Sizes = std::pair<size_t, size_t>;
  const Sizes sizes = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, samples, 8), Sizes{0, 0},
      [&](const tbb::blocked_range<size_t>& r, Sizes sum) {
        for (const uint32_t flags : {uint32_t(openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK),
                                     uint32_t(openvdb::io::COMPRESS_ACTIVE_MASK)}) {
          AppendBuffer buffer;
          std::ostream out(&buffer);
          openvdb::io::setDataCompression(out, flags);
          openvdb::io::setGridBackgroundValuePtr(out, &background);
          for (size_t i = r.begin(); i != r.end(); ++i) leaves[i * kEvery]->writeBuffers(out, false);
          (flags & openvdb::io::COMPRESS_BLOSC ? sum.first : sum.second) += buffer.bytes.size();
        }
        return sum;
      },
      [](Sizes a, const Sizes& b) {
        return Sizes{a.first + b.first, a.second + b.second};
      });
  return double(sizes.first) <= ratio * double(sizes.second);
}

void writeLeafBuffersParallel(const openvdb::FloatTree& tree, std::ostream& os, bool toHalf) {
  const auto leaves = leavesInOrder(tree);
  // 256 leaves (512 KiB of floats) a batch: enough work per task to hide its overhead, small enough that the
  // batches in flight (two per thread) stay a few MB.
  constexpr size_t kBatchLeaves = 256;
  const size_t batches = (leaves.size() + kBatchLeaves - 1) / kBatchLeaves;
  const size_t tokens = 2 * static_cast<size_t>(tbb::this_task_arena::max_concurrency()) + 1;
  // Batch b uses buffer b % tokens: the pipeline admits no more than `tokens` batches and retires them in order, so
  // the batch that used it before has been written.
  std::vector<AppendBuffer> buffers(std::min(tokens, std::max<size_t>(batches, 1)));
  // Values stored as they are (mask compression alone): most leaves are appended without OpenVDB's writer.
  const bool fast = openvdb::io::getDataCompression(os) == openvdb::io::COMPRESS_ACTIVE_MASK && !toHalf;
  const void* backgroundPtr = openvdb::io::getGridBackgroundValuePtr(os);
  const float background = backgroundPtr ? *static_cast<const float*>(backgroundPtr) : 0.0f;
  size_t next = 0;
  tbb::parallel_pipeline(
      tokens, tbb::make_filter<void, size_t>(tbb::filter_mode::serial_in_order, [&](tbb::flow_control& fc) -> size_t {
                if (next == batches) fc.stop();
                return next++;
              }) & tbb::make_filter<size_t, AppendBuffer*>(tbb::filter_mode::parallel, [&](size_t batch) {
                AppendBuffer* buffer = &buffers[batch % buffers.size()];
                buffer->bytes.clear();
                // copyfmt carries OpenVDB's per-stream state (iword/pword: compression flags, background,
                // stream metadata) over to the batch's stream, so each leaf writes as it would into `os`.
                std::ostream out(buffer);
                out.copyfmt(os);
                const size_t end = std::min(leaves.size(), (batch + 1) * kBatchLeaves);
                for (size_t i = batch * kBatchLeaves; i < end; ++i)
                  if (!fast || !appendMaskCompressedLeaf(*leaves[i], background, buffer->bytes))
                    leaves[i]->writeBuffers(out, toHalf);
                return buffer;
              }) & tbb::make_filter<AppendBuffer*, void>(tbb::filter_mode::serial_in_order, [&](AppendBuffer* buffer) {
                os.write(buffer->bytes.data(), static_cast<std::streamsize>(buffer->bytes.size()));
              }));
}

}  // namespace voxbrick::store
