// One z-chunk of level 0 as the leaves of an OpenVDB float tree, kept as the bytes a .vdb file stores for them, and
// the file written from them without building the tree. Internal to brickstore/ (it includes OpenVDB).
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <ostream>
#include <vector>

#include <openvdb/openvdb.h>

#include "brickstore/format/Types.h"

namespace voxbrick::store {

/// The voxels of slices [z0, z1) of a dims.x x dims.y x dims.z volume, cut into 8^3 leaves as they arrive, for one
/// .vdb file whose grid is the tree that tools::copyFromDense (tolerance 0) and then tools::pruneTiles (tolerance 0)
/// build from that box: a voxel equal to the background is inactive (a NaN counts as the background), a whole 8^3
/// block of one active value is a tile, as is a whole node of such tiles of one value. write() gives byte for byte
/// the file openvdb::io::File writes for that tree (its random UUID apart), without the tree: each leaf is kept as it
/// is written (value mask, the mask-compression byte and its active values), so the file is the leaves copied out in
/// the tree's order behind a header, metadata and topology made from the chunk's cells.
class VdbLeafChunk {
 public:
  VdbLeafChunk(const Vec3i& dims, float background);
  ~VdbLeafChunk();
  VdbLeafChunk(const VdbLeafChunk&) = delete;
  VdbLeafChunk& operator=(const VdbLeafChunk&) = delete;

  /// Starts the chunk of slices [z0, z1), forgetting the previous one (its memory is kept for the next).
  void begin(int64_t z0, int64_t z1);
  /// Forgets the chunk and frees its memory.
  void release();
  /// Adds `count` slices (x fastest, then y), the first at z = `z0`: the next ones of the chunk, in order, in calls
  /// of any size. Whole leaf layers are cut from `values` on every thread; a layer that a call leaves unfinished is
  /// copied aside until the next call completes it.
  template <typename T>
  void addSlices(const T* values, int64_t z0, int64_t count);
  /// True once every slice of the chunk has been added.
  bool complete() const { return mNextZ == mZ1; }

  /// Whether blosc (as OpenVDB writes a leaf with it) shrinks the chunk's leaves to at most `ratio` of their size
  /// without it, judged on every 16th leaf in the tree's order: the same chunk always gives the same answer, whatever
  /// the threads. True for a chunk without leaves.
  bool bloscShrinksTo(double ratio);

  /// Writes the complete chunk to `path` as openvdb::io::File would write `grid` (its name, class, transform and
  /// metadata; its tree is ignored, but for the background) with this chunk's tree, with blosc or with the active
  /// mask alone. Blosc compresses the kept leaves in place. Returns the file's size. Throws IoError.
  int64_t write(const std::filesystem::path& path, const openvdb::FloatGrid& grid, bool blosc);

  /// Leaves of the complete chunk's tree.
  int64_t leafCount();
  /// Bytes the leaves of a chunk of `slices` slices of `dims` hold at most, with its cell table.
  static int64_t maxBytes(const Vec3i& dims, int64_t slices);

 private:
  enum class Kind : uint8_t { Empty, Tile, Leaf };
  /// One 8^3 block of the chunk: nothing, an active tile, or a kept leaf (`size` bytes at `offset` in the pool, room
  /// for 8 more: blosc's size word when it does not shrink them).
  struct Cell {
    uint64_t offset = 0;
    uint32_t size = 0;
    uint16_t count = 0;  ///< active voxels
    Kind kind = Kind::Empty;
    float tile = 0;
  };
  struct Layout;
  const Layout& layout();  ///< made once the chunk is complete

  template <typename T>
  void cutLayer(const T* values, int64_t zs, int64_t slices);
  /// LeafNode::writeBuffers of a kept leaf, to a stream tagged as OpenVDB tags it.
  void writeLeafBuffers(const Cell& cell, std::ostream& os) const;
  /// Each kept leaf replaced by its form under `compression` (blosc), in place.
  void compressLeaves(uint32_t compression);
  /// The grid's metadata as Archive::writeGrid writes it: statistics and the delayed-load record added.
  openvdb::MetaMap fileMetadata(const openvdb::FloatGrid& grid, uint32_t archiveCompression, uint32_t compression);
  /// Tree::writeTopology of the chunk's tree, made from its layout.
  void writeTopology(std::ostream& os);
  size_t cellIndex(int64_t lx, int64_t ly, int64_t layer) const {
    return size_t((layer * mLeavesY + ly) * mLeavesX + lx);
  }
  void expand(const Cell& cell, float* values) const;

  Vec3i mDims;
  float mBackground;
  int64_t mLeavesX, mLeavesY;
  int64_t mZ0 = 0, mZ1 = 0, mNextZ = 0;
  int64_t mFirstLayer = 0, mLayers = 0;
  std::vector<Cell> mCells;
  std::unique_ptr<char[]> mPool;
  size_t mPoolCapacity = 0;
  std::atomic<uint64_t> mPoolUsed{0};
  std::vector<char> mCarry;  ///< slices of an unfinished layer, as given
  int64_t mCarryZ = 0, mCarrySlices = 0;
  std::unique_ptr<struct ScratchSet> mScratch;
  std::unique_ptr<Layout> mLayout;
};

}  // namespace voxbrick::store
