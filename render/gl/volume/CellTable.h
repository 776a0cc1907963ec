// The frame ray caster's cell table (render/gl/volume/RayCastPass.h): the volume cut into cells of C level-0 voxels
// (the frame's sub-blocks, or its bricks), each holding the atlas payload of the brick that owns it in the current
// batch and that brick's level, or "nothing to draw" (a cell of an empty sub-block, a skipped or culled brick), or "a
// brick of another batch". One RGBA16I entry per cell: for a drawn cell xyz is what raycast.frag.glsl adds to a
// sample's voxel coordinate in the brick's level to find its atlas texel and w the level; otherwise w is kNothing
// or kOtherBatch.
//
// The host keeps the table paged, so that its size follows what is drawn rather than the volume: cells are grouped
// in blocks of kLeapBlock^3, a directory holds each block's page, or kBlockNothing (every cell has nothing to draw)
// or kBlockOtherBatch (every cell is another batch's), and pages hold kPageCells entries each, x fastest. A sparse
// volume of any size needs pages for its drawn blocks only; a block with nothing to draw costs one directory entry.
// On the GPU a table of at most kMaxDenseCells cells is one RGBA16I 3D texture of cells (texture unit VB_UNIT_CELLS;
// a sample reads one entry); a larger one (FramePlan::pagedCells, PAGED_CELLS in the shaders) is the directory, an
// R32I 3D texture of blocks (VB_UNIT_CELL_DIRECTORY), over the pages in a buffer texture (VB_UNIT_CELLS) that grows
// as pages are needed (a sample reads a directory entry, then a page's).
//
// The two kinds of "nothing" differ for the ray. A cell with nothing to draw adds nothing even at points on its
// faces, since its value range covers every sample that reads its voxels, so a ray may leap to where it leaves the
// cell, and further: such a cell's x holds j, the largest (up to kMaxLeapLevel) such that the aligned block of 2^j
// cells around it has nothing to draw, and the ray leaps out of that block (a block without a page: out of the whole
// block). A cell of a brick drawn in another batch must be stepped through plane by plane near its faces, where a
// point may belong to a neighbour of this batch. A whole frame drawn in one batch has no such cells; a part's frame
// (sort-last rendering) has them just outside its box (deferOutside), however many batches it takes.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "render/gl/GlObjects.h"

namespace voxbrick::render {

struct QueuedBox;
struct TraversalResult;

class CellTable {
 public:
  explicit CellTable(const Gl& gl);

  /// Cell levels (w) that are not a brick's level.
  static constexpr int16_t kNothing = -1, kOtherBatch = -2;
  /// The largest block a ray leaps over at once: 2^kMaxLeapLevel cells a side.
  static constexpr int kMaxLeapLevel = 3;
  /// Cells a side of a block: a page of the table, and the block whose leaps depend on its own cells only.
  static constexpr int kLeapBlock = 1 << kMaxLeapLevel;
  static constexpr int kPageCells = kLeapBlock * kLeapBlock * kLeapBlock;
  /// Directory entries of a block without a page: every cell has nothing to draw (a ray leaps out of the block), or
  /// every cell is a brick's of another batch.
  static constexpr int32_t kBlockNothing = -1, kBlockOtherBatch = -2;

  /// Starts a frame of batches: a table of `cellSize` (a power of two) voxel cells over `dims` voxels, every cell
  /// with nothing to draw, filled for each batch by add() and sent by upload(); on the GPU paged or one grid.
  void begin(const glm::ivec3& dims, int cellSize, bool paged);
  /// For a frame of several batches, after begin(): marks the cells of every brick of `visible` (bricks of
  /// `brickSize` level-0 voxels at level 0) as drawn in another batch, what they return to after each batch.
  void deferAll(const TraversalResult& visible, int brickSize);
  /// For a part's frame (sort-last rendering), after begin() and deferAll(): marks the cells just outside the part
  /// [lo, hi) (level-0 voxels on cell boundaries, or the volume's far faces), one cell deep, as drawn in another
  /// batch, which they are (by another part), so that rays step through them plane by plane near the part's faces
  /// and never leap over a point the part owns. Cells further out have nothing to draw.
  void deferOutside(const glm::ivec3& lo, const glm::ivec3& hi);
  /// Marks the cells of `box` (its owned voxels, aligned to the cell size except at the volume's far faces) as drawn
  /// from its payload. Throws RenderError if the payload does not fit 16 bits (an atlas beyond 32767 texels).
  void add(const QueuedBox& box);
  /// Whether no cell has been marked since begin() or the last upload().
  bool empty() const { return !mMarked; }
  /// Computes the leaps, uploads the table, binds it (texture unit VB_UNIT_CELLS, and VB_UNIT_CELL_DIRECTORY) and
  /// resets the host copy for the next batch (the GPU keeps this batch's cells until the next upload). Returns the
  /// cells sent (pages and directory).
  int64_t upload();

  /// A kept table, for frames of one batch: the host copy and the GPU's stay from frame to frame and change only
  /// where told, by clear() and add(); uploadChanges() recomputes the leaps of the changed blocks and sends only
  /// them. Starts such a frame over `dims` voxels in cells of `cellSize`; returns false when the table was not kept
  /// (the first such frame, another grid, or a frame of batches since): every cell then has nothing to draw.
  bool resume(const glm::ivec3& dims, int cellSize, bool paged);
  /// The next resume() starts a new table.
  void drop() { mKept = false; }
  /// In a kept table: the cells of level-0 voxels [lo, hi) (on cell boundaries) back to nothing to draw.
  void clear(const glm::ivec3& lo, const glm::ivec3& hi);
  /// In a kept table: the leaps of the blocks clear() and add() changed, their pages and directory entries sent, and
  /// the table bound. Returns the cells sent.
  int64_t uploadChanges();

  glm::ivec3 cells() const { return mCells; }
  /// log2 of the cell size.
  int shift() const { return mShift; }
  /// Pages the host table holds now (blocks with something other than nothing to draw).
  int64_t pages() const { return int64_t(mPageCount - mFreePages.size()); }
  /// What the GPU holds, read back as one entry per cell (x fastest; a block without a page as kNothing with leap
  /// kMaxLeapLevel, what the shader reads there): for tests. Waits for the GPU.
  std::vector<glm::i16vec4> readBack() const;

 private:
  size_t blockIndex(const glm::ivec3& b) const {
    return (size_t(b.z) * size_t(mBlocks.y) + size_t(b.y)) * size_t(mBlocks.x) + size_t(b.x);
  }
  void setGrid(const glm::ivec3& dims, int cellSize, bool paged);  // an empty table: every block without a page
  /// Sets cells [c0, c1) to `entry`; blocks without a page get one unless `entry` is nothing to draw.
  void fill(const glm::ivec3& c0, const glm::ivec3& c1, const glm::i16vec4& entry);
  int32_t newPage(const glm::i16vec4& entry);  // a page of `entry` everywhere
  void touch(const glm::ivec3& b0, const glm::ivec3& b1);  // blocks [b0, b1) changed
  /// Leaps of block `b`'s page; a page with nothing to draw at all is freed (the block's directory entry says so).
  void settle(const glm::ivec3& b);
  bool reservePool();  // the pool buffer holds every page; true when it is a new buffer (holding none yet)
  int64_t sendPages(std::vector<int32_t>& pages);      // those pages (sorted, in runs)
  void sendDirectoryRun(const glm::ivec3& b, int n);  // n directory entries from block b along x
  void bind() const;
  /// The cells of block `b` (a page, or the block's one entry everywhere), kPageCells of them, x fastest.
  const glm::i16vec4* blockCells(const glm::ivec3& b) const;
  int64_t sendDense();                                 // one grid: every cell
  int64_t sendDenseBlock(const glm::ivec3& b);         // one grid: block b's cells
  void reset();  // back to the frame's base: every cell nothing to draw, or drawn in another batch where deferred

  const Gl& mGl;
  Texture mDirectoryTexture, mPoolTexture;  // R32I 3D; RGBA16I buffer texture over mPoolBuffer
  Buffer mPoolBuffer;
  Texture mDenseTexture;  // one grid: RGBA16I 3D, a texel a cell
  glm::ivec3 mDenseCells{0}, mDirectoryBlocks{0};  // the sizes the textures were made for
  std::vector<glm::i16vec4> mDense;  // one grid: the host copy sendDense() assembles
  bool mPaged = true;
  size_t mPoolCapacity = 0;  // pages the buffer holds
  glm::ivec3 mCells{0}, mBlocks{0};
  int mShift = 0;
  std::vector<int32_t> mDirectory;  // per block: its page, or kBlockNothing or kBlockOtherBatch
  std::vector<glm::i16vec4> mPool;  // kPageCells entries a page
  std::vector<int32_t> mFreePages;
  int32_t mPageCount = 0;  // pages in mPool, free or not
  // A frame of batches: the table each batch starts from (after deferAll and deferOutside).
  std::vector<int32_t> mBaseDirectory, mBaseFree;
  std::vector<glm::i16vec4> mBasePool;
  int32_t mBasePageCount = 0;
  bool mMarked = false;
  // A kept table: whether the host copy and the GPU hold it, the blocks changed since it was last sent, the box
  // around them (in blocks).
  bool mKept = false;
  std::vector<uint8_t> mChanged;
  glm::ivec3 mChangedLo{0}, mChangedHi{0};
};

/// Sets x of every cell of one page (kPageCells entries, x fastest) whose w is CellTable::kNothing to the largest
/// j <= CellTable::kMaxLeapLevel such that the aligned block of 2^j cells a side around it has nothing to draw, 0
/// when none. Returns whether every cell of the page has nothing to draw.
bool computePageLeaps(glm::i16vec4* page);

}  // namespace voxbrick::render
