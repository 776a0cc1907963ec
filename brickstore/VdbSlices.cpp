// Dense slices into an OpenVDB tree: the blocks and the order of tools::CopyFromDense, with whole leaves filled by a
// direct loop and partial ones by OpenVDB's own LeafNode::copyFromDense.
#include "brickstore/VdbSlices.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include <openvdb/tools/Dense.h>
#include <openvdb/tools/Prune.h>

namespace voxbrick::store {
namespace {

using Leaf = openvdb::FloatTree::LeafNodeType;
constexpr int kDim = int(Leaf::DIM);

/// One leaf-sized part of the box, as CopyFromDense cuts it, and what became of it.
struct Block {
  openvdb::CoordBBox bbox;
  Leaf* leaf = nullptr;  ///< a leaf to add, or null
  float tileValue = 0;   ///< else: the constant value and state (a tile if active)
  bool tileOn = false;
};

/// Fills `leaf` from a whole 8^3 block of the slices: every voxel is written, so nothing before matters.
template <typename T>
void fillWholeLeaf(Leaf& leaf, const T* values, const Vec3i& dims, int64_t z0, const openvdb::Coord& origin,
                   float background) {
  float* buffer = leaf.buffer().data();
  // Leaf offset n = x << 6 | y << 3 | z, so mask word x holds bit (y << 3 | z): gathered in registers, no branches.
  uint64_t words[kDim] = {};
  for (int lz = 0; lz < kDim; ++lz)
    for (int ly = 0; ly < kDim; ++ly) {
      const T* row = values + ((int64_t(origin.z() + lz) - z0) * dims.y + origin.y() + ly) * dims.x + origin.x();
      const int bit = (ly << 3) | lz;
      for (int lx = 0; lx < kDim; ++lx) {
        const float v = static_cast<float>(row[lx]);
        // !math::isApproxEqual(background, v, 0): a NaN counts as the background, as in LeafNode::copyFromDense.
        const bool on = std::abs(background - v) > 0.0f;
        buffer[(lx << 6) | bit] = on ? v : background;
        words[lx] |= uint64_t(on) << bit;
      }
    }
  Leaf::NodeMaskType mask;
  for (int w = 0; w < kDim; ++w) mask.template getWord<uint64_t>(openvdb::Index(w)) = words[w];
  leaf.setValueMask(mask);
}

}  // namespace

template <typename T>
void addSlicesToTree(openvdb::FloatTree& tree, const T* values, const Vec3i& dims, int64_t z0, int64_t count) {
  if (count <= 0) return;
  const openvdb::CoordBBox box(openvdb::Coord(0, 0, int(z0)),
                               openvdb::Coord(int(dims.x - 1), int(dims.y - 1), int(z0 + count - 1)));
  std::vector<Block> blocks;     // x, then y, then z: CopyFromDense's order
  int64_t rowsY = 0, rowsZ = 0;  // blocks along y and z
  for (openvdb::CoordBBox sub = box; sub.min()[0] <= box.max()[0]; sub.min()[0] = sub.max()[0] + 1)
    for (sub.min()[1] = box.min()[1], rowsY = 0; sub.min()[1] <= box.max()[1]; sub.min()[1] = sub.max()[1] + 1, ++rowsY)
      for (sub.min()[2] = box.min()[2], rowsZ = 0; sub.min()[2] <= box.max()[2];
           sub.min()[2] = sub.max()[2] + 1, ++rowsZ) {
        sub.max() = openvdb::Coord::minComponent(box.max(), (sub.min() & ~(kDim - 1)).offsetBy(kDim - 1));
        blocks.push_back({sub});
      }
  const int64_t rowsX = int64_t(blocks.size()) / std::max<int64_t>(1, rowsY * rowsZ);
  const float background = tree.background();
  const bool treeEmpty = tree.empty();
  // Dense wants a mutable pointer; LeafNode::copyFromDense only reads through it.
  const openvdb::tools::Dense<T, openvdb::tools::LayoutXYZ> dense(box, const_cast<T*>(values));
  // Filled a row of blocks along x at a time (the order of the slices' memory: each of the 64 rows of 8 values a
  // leaf reads continues the one its neighbour read), not in the blocks' order, which jumps 8 slices every block.
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, rowsY * rowsZ), [&](const tbb::blocked_range<int64_t>& rows) {
    openvdb::tree::ValueAccessor<const openvdb::FloatTree> acc(tree);
    std::unique_ptr<Leaf> spare;
    for (int64_t b = rows.begin() * rowsX; b != rows.end() * rowsX; ++b) {
      const int64_t row = b / rowsX, bz = row / rowsY, by = row % rowsY, bx = b % rowsX;
      Block& block = blocks[size_t((bx * rowsY + by) * rowsZ + bz)];
      const openvdb::Coord origin = block.bbox.min() & ~(kDim - 1);
      if (!spare) spare = std::make_unique<Leaf>(openvdb::PartialCreate(), origin, background, false);
      spare->allocate();
      spare->setOrigin(origin);
      if (block.bbox.volume() == Leaf::SIZE) {
        fillWholeLeaf(*spare, values, dims, z0, origin, background);
      } else {
        // As CopyFromDense: start from what the tree holds there (a leaf an earlier call began, or a tile).
        if (treeEmpty) {
          spare->fill(background, false);
        } else if (const Leaf* existing = acc.probeConstLeaf(block.bbox.min())) {
          *spare = *existing;
        } else {
          float value = 0;
          const bool on = acc.probeValue(block.bbox.min(), value);
          spare->fill(value, on);
        }
        spare->copyFromDense(block.bbox, dense, background, 0.0f);
      }
      if (!spare->isConstant(block.tileValue, block.tileOn, 0.0f)) {
        spare->setOrigin(origin);
        block.leaf = spare.release();
      }
    }
  });
  openvdb::tree::ValueAccessor<openvdb::FloatTree> acc(tree);
  for (const Block& block : blocks) {
    if (block.leaf)
      acc.addLeaf(block.leaf);
    else if (block.tileOn)  // an inactive constant block holds the background: nothing to add
      acc.addTile(1, block.bbox.min(), block.tileValue, true);
  }
  openvdb::tools::pruneTiles(tree, 0.0f);
}

template void addSlicesToTree(openvdb::FloatTree&, const uint8_t*, const Vec3i&, int64_t, int64_t);
template void addSlicesToTree(openvdb::FloatTree&, const uint16_t*, const Vec3i&, int64_t, int64_t);
template void addSlicesToTree(openvdb::FloatTree&, const int16_t*, const Vec3i&, int64_t, int64_t);
template void addSlicesToTree(openvdb::FloatTree&, const float*, const Vec3i&, int64_t, int64_t);

}  // namespace voxbrick::store
