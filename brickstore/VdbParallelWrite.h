// An OpenVDB float grid whose leaf buffers are compressed on every thread when it is written: the same bytes as
// OpenVDB's own serial writer, in a fraction of the wall time. Internal to brickstore/ (it includes OpenVDB).
#pragma once

#include <ostream>

#include <openvdb/openvdb.h>

namespace voxbrick::store {

/// Writes the leaf buffers of `tree` to `os` exactly as `tree.writeBuffers(os, toHalf)` does (same bytes, same order,
/// the stream's compression and background as OpenVDB's writer set them), compressing batches of leaves in parallel and
/// appending them in order. Holds at most a few batches of compressed leaves at once.
void writeLeafBuffersParallel(const openvdb::FloatTree& tree, std::ostream& os, bool toHalf);

/// Whether blosc (as OpenVDB writes it) shrinks the leaf values of `tree` to at most `ratio` of their size without
/// it, judged on every 16th leaf in leaf order: the same tree always gives the same answer, whatever the threads.
/// True for an empty tree.
bool bloscShrinksTo(const openvdb::FloatTree& tree, double ratio);

/// A FloatGrid that io::File::write writes with writeLeafBuffersParallel: the file is byte for byte what a plain
/// FloatGrid with the same tree, transform and metadata gives (OpenVDB's random file UUID apart).
class ParallelWriteFloatGrid final : public openvdb::FloatGrid {
 public:
  using Ptr = std::shared_ptr<ParallelWriteFloatGrid>;
  explicit ParallelWriteFloatGrid(float background)
      : openvdb::FloatGrid(std::make_shared<openvdb::FloatTree>(background)) {}
  /// Shares `tree` (not a copy).
  explicit ParallelWriteFloatGrid(openvdb::FloatTree::Ptr tree) : openvdb::FloatGrid(std::move(tree)) {}
  void writeBuffers(std::ostream& os) const override { writeLeafBuffersParallel(tree(), os, saveFloatAsHalf()); }
};

}  // namespace voxbrick::store
