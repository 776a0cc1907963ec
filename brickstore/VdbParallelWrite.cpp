// Parallel leaf-buffer writing for OpenVDB float grids: batches of leaves compressed into strings on every thread,
// appended to the stream in the tree's leaf order by a serial stage.
#include "brickstore/VdbParallelWrite.h"

#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <streambuf>
#include <string>
#include <vector>

namespace voxbrick::store {
namespace {

/// A stream buffer appending to a vector that keeps its capacity from batch to batch.
class AppendBuffer : public std::streambuf {
 public:
  std::vector<char> bytes;

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

}  // namespace

void writeLeafBuffersParallel(const openvdb::FloatTree& tree, std::ostream& os, bool toHalf) {
  using Leaf = openvdb::FloatTree::LeafNodeType;
  // Tree::writeBuffers visits the leaves depth first in coordinate order, as the leaf iterator does.
  std::vector<const Leaf*> leaves;
  leaves.reserve(tree.leafCount());
  for (auto it = tree.cbeginLeaf(); it; ++it) leaves.push_back(it.getLeaf());
  // 256 leaves (512 KiB of floats) a batch: enough work per task to hide its overhead, small enough that the
  // batches in flight (two per thread) stay a few MB.
  constexpr size_t kBatchLeaves = 256;
  const size_t batches = (leaves.size() + kBatchLeaves - 1) / kBatchLeaves;
  const size_t tokens = 2 * static_cast<size_t>(tbb::this_task_arena::max_concurrency()) + 1;
  // Batch b uses buffer b % tokens: the pipeline admits no more than `tokens` batches and retires them in order, so
  // the batch that used it before has been written.
  std::vector<AppendBuffer> buffers(std::min(tokens, std::max<size_t>(batches, 1)));
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
                for (size_t i = batch * kBatchLeaves; i < end; ++i) leaves[i]->writeBuffers(out, toHalf);
                return buffer;
              }) & tbb::make_filter<AppendBuffer*, void>(tbb::filter_mode::serial_in_order, [&](AppendBuffer* buffer) {
                os.write(buffer->bytes.data(), static_cast<std::streamsize>(buffer->bytes.size()));
              }));
}

}  // namespace voxbrick::store
