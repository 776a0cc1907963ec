// The frame ray caster's cell table (render/gl/volume/RayCastPass.h): the volume cut into cells of C level-0 voxels
// (the frame's sub-blocks, or its bricks), each holding the atlas payload of the brick that owns it in the current
// batch and that brick's level, or "nothing to draw" (a cell of an empty sub-block, a skipped or culled brick), or "a
// brick of another batch". One RGBA16I texel per cell, on texture unit VB_UNIT_CELLS: for a drawn cell xyz is what
// raycast.frag.glsl adds to a sample's voxel coordinate in the brick's level to find its atlas texel and w the
// level; otherwise w is kNothing or kOtherBatch.
//
// The two kinds of "nothing" differ for the ray. A cell with nothing to draw adds nothing even at points on its
// faces, since its value range covers every sample that reads its voxels, so a ray may leap to where it leaves the
// cell, and further: such a cell's x holds j, the largest (up to kMaxLeapLevel) such that the aligned block of 2^j
// cells around it has nothing to draw, and the ray leaps out of that block. A cell of a brick drawn in another batch
// must be stepped through plane by plane near its faces, where a point may belong to a neighbour of this batch.
// A whole frame drawn in one batch has no such cells; a part's frame (sort-last rendering) has them just outside
// its box (deferOutside), however many batches it takes.
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
  explicit CellTable(const Gl& gl) : mGl(gl) {}

  /// Cell levels (w) that are not a brick's level.
  static constexpr int16_t kNothing = -1, kOtherBatch = -2;
  /// The largest block a ray leaps over at once: 2^kMaxLeapLevel cells a side.
  static constexpr int kMaxLeapLevel = 3;
  /// Cells a side of a block whose leaps depend on its own cells only (the largest leap's block).
  static constexpr int kLeapBlock = 1 << kMaxLeapLevel;

  /// Starts a frame of batches: a table of `cellSize` (a power of two) voxel cells over `dims` voxels, every cell
  /// with nothing to draw, filled for each batch by add() and sent by upload(). The texture is (re)made when the
  /// cell grid changes.
  void begin(const glm::ivec3& dims, int cellSize);
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
  /// Computes the leaps, uploads the table, binds it to texture unit 4 and resets the host copy for the next batch
  /// (the texture keeps this batch's cells until the next upload).
  void upload();

  /// A kept table, for frames of one batch: the host copy and the texture stay from frame to frame and change only
  /// where told, by clear() and add(); uploadChanges() recomputes the leaps of the changed blocks and sends only
  /// them. Starts such a frame over `dims` voxels in cells of `cellSize`; returns false when the table was not kept
  /// (the first such frame, another grid, or a frame of batches since): every cell then has nothing to draw.
  bool resume(const glm::ivec3& dims, int cellSize);
  /// The next resume() starts a new table.
  void drop() { mKept = false; }
  /// In a kept table: the cells of level-0 voxels [lo, hi) (on cell boundaries) back to nothing to draw.
  void clear(const glm::ivec3& lo, const glm::ivec3& hi);
  /// In a kept table: the leaps of the blocks clear() and add() changed, those blocks sent to the texture (in each row
  /// of blocks, the run from its first changed block to its last), and the texture bound to texture unit 4. Returns
  /// the cells sent.
  int64_t uploadChanges();

  glm::ivec3 cells() const { return mCells; }
  /// log2 of the cell size.
  int shift() const { return mShift; }

 private:
  size_t index(int x, int y, int z) const {
    return (size_t(z) * size_t(mCells.y) + size_t(y)) * size_t(mCells.x) + size_t(x);
  }
  /// Cells [c0, c1) were changed: their blocks' leaps must be recomputed and sent (a kept table).
  void touch(const glm::ivec3& c0, const glm::ivec3& c1);
  void makeTexture(const glm::ivec3& cells, int cellSize);  // when the grid changes
  void send(const glm::ivec3& lo, const glm::ivec3& hi);     // host cells [lo, hi) to the texture
  void reset();  // every cell back to kNothing, or kOtherBatch where deferred

  const Gl& mGl;
  Texture mTexture;
  glm::ivec3 mCells{0};
  int mShift = 0;
  std::vector<glm::i16vec4> mHost;
  std::vector<uint8_t> mDeferred;  // per cell: 1 where a brick of another batch of this frame owns it
  bool mMarked = false;
  // A kept table: whether the host copy and the texture hold it, the blocks changed since it was last sent (one
  // flag per kLeapBlock^3 cells) and the box around them, in blocks.
  bool mKept = false;
  glm::ivec3 mBlocks{0};
  std::vector<uint8_t> mChanged;
  glm::ivec3 mChangedLo{0}, mChangedHi{0};
};

/// Sets x of every cell of `cells` (a grid of `grid` cells, x fastest) whose w is CellTable::kNothing to the
/// largest j <= CellTable::kMaxLeapLevel such that the aligned block of 2^j cells a side around it has nothing to
/// draw (cells past the grid count as nothing: no ray samples there), 0 when none.
void computeLeaps(std::vector<glm::i16vec4>& cells, const glm::ivec3& grid);

/// computeLeaps for the cells of one aligned block of CellTable::kLeapBlock cells a side, `block` (in blocks): a
/// cell's leap depends on the cells of its block alone.
void computeBlockLeaps(std::vector<glm::i16vec4>& cells, const glm::ivec3& grid, const glm::ivec3& block);

}  // namespace voxbrick::render
