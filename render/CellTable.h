// The frame ray caster's cell table (render/RayCastPass.h): the volume cut into cells of C level-0 voxels (the
// frame's sub-blocks, or its bricks), each holding the atlas payload of the brick that owns it in the current batch
// and that brick's level, or "nothing to draw" (a cell of an empty sub-block, a skipped or culled brick, or a brick
// of another batch). One RGBA16I texel per cell (xyz: what volume.frag.glsl adds to a sample's voxel coordinate in
// the brick's level to find its atlas texel; w: the level, or kNothing, or kOtherBatch), on texture unit 4.
//
// The two kinds of "nothing" differ for the ray: a cell with nothing to draw at all (empty under the transfer
// function, or outside the view) adds nothing even at points on its faces, since its value range covers every
// sample that reads its voxels, so a ray may leap to where it leaves the cell; a cell of a brick drawn in another
// batch must be stepped through plane by plane near its faces, where a point may belong to a neighbour of this
// batch. Frames of one batch have no such cells.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "render/GlObjects.h"

namespace voxbrick::render {

struct QueuedBox;
struct TraversalResult;

class CellTable {
 public:
  explicit CellTable(const Gl& gl) : mGl(gl) {}

  /// Cell levels (w) that are not a brick's level.
  static constexpr int16_t kNothing = -1, kOtherBatch = -2;

  /// Starts a frame: a table of `cellSize` (a power of two) voxel cells over `dims` voxels, every cell empty. The
  /// texture is (re)made when the cell grid changes.
  void begin(const glm::ivec3& dims, int cellSize);
  /// For a frame of several batches, after begin(): marks the cells of every brick of `visible` (bricks of
  /// `brickSize` level-0 voxels at level 0) as drawn in another batch, what they return to after each batch.
  void deferAll(const TraversalResult& visible, int brickSize);
  /// Marks the cells of `box` (its owned voxels, aligned to the cell size except at the volume's far faces) as drawn
  /// from its payload. Throws RenderError if the payload does not fit 16 bits (an atlas beyond 32767 texels).
  void add(const QueuedBox& box);
  /// Whether no cell has been marked since the last begin() or upload().
  bool empty() const { return mTouchedLo > mTouchedHi; }
  /// Uploads the marked cells, binds the table to texture unit 4 and clears the host copy for the next batch
  /// (the texture keeps this batch's cells until the next upload).
  void upload();

  glm::ivec3 cells() const { return mCells; }
  /// log2 of the cell size.
  int shift() const { return mShift; }
  /// The number of cells a table over `dims` voxels with `cellSize` cells has.
  static int64_t cellCount(const glm::ivec3& dims, int cellSize);

 private:
  size_t index(int x, int y, int z) const { return (size_t(z) * size_t(mCells.y) + size_t(y)) * size_t(mCells.x) + size_t(x); }

  const Gl& mGl;
  Texture mTexture;
  glm::ivec3 mCells{0};
  int mShift = 0;
  void clearLayers(int lo, int hi);  // cells of layers [lo, hi] back to kNothing, or kOtherBatch where deferred

  std::vector<glm::i16vec4> mHost;
  std::vector<uint8_t> mDeferred;  // per cell: 1 where a brick of another batch of this frame owns it
  int mTouchedLo = 1, mTouchedHi = 0;  // the z range of cell layers marked since the last upload, inclusive
  int mUploadedLo = 1, mUploadedHi = 0;  // the layers the texture holds marks in (cleared at the next upload)
};

}  // namespace voxbrick::render
