// Parallel leaf-buffer writing for OpenVDB float grids: batches of leaves compressed into strings on every thread,
// appended to the stream in the tree's leaf order by a serial stage.
#include "brickstore/VdbParallelWrite.h"

#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

namespace voxbrick::store {

void writeLeafBuffersParallel(const openvdb::FloatTree& tree, std::ostream& os, bool toHalf) {
  using Leaf = openvdb::FloatTree::LeafNodeType;
  // Tree::writeBuffers visits the leaves depth first in coordinate order, as the leaf iterator does.
  std::vector<const Leaf*> leaves;
  leaves.reserve(tree.leafCount());
  for (auto it = tree.cbeginLeaf(); it; ++it) leaves.push_back(it.getLeaf());
  // 256 leaves (512 KiB of floats) a batch: enough work per task to hide its overhead, small enough that the
  // batches in flight (a few per thread) stay a few MB.
  constexpr size_t kBatchLeaves = 256;
  const size_t batches = (leaves.size() + kBatchLeaves - 1) / kBatchLeaves;
  const size_t tokens = 2 * static_cast<size_t>(tbb::this_task_arena::max_concurrency()) + 1;
  size_t next = 0;
  tbb::parallel_pipeline(
      tokens,
      tbb::make_filter<void, size_t>(tbb::filter_mode::serial_in_order, [&](tbb::flow_control& fc) -> size_t {
        if (next == batches) fc.stop();
        return next++;
      }) & tbb::make_filter<size_t, std::string>(tbb::filter_mode::parallel, [&](size_t batch) {
        // copyfmt carries OpenVDB's per-stream state (iword/pword: compression flags, background,
        // stream metadata) over to the batch's stream, so each leaf writes as it would into `os`.
        std::ostringstream out;
        out.copyfmt(os);
        const size_t end = std::min(leaves.size(), (batch + 1) * kBatchLeaves);
        for (size_t i = batch * kBatchLeaves; i < end; ++i) leaves[i]->writeBuffers(out, toHalf);
        return std::move(out).str();
      }) & tbb::make_filter<std::string, void>(tbb::filter_mode::serial_in_order, [&](const std::string& bytes) {
        os.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
      }));
}

}  // namespace voxbrick::store
