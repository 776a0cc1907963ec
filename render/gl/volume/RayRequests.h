// Ray-driven residency (Scene::residency rays; GigaVoxels, Crassin et al. 2009; Hadwiger et al. 2012): the rays, not
// the octree walk, decide which bricks of a ray-cast frame of one batch are paged into the atlas.
//
// A brick the octree finds visible but that is not resident is drawn from its nearest resident ancestor (a stand-in;
// the ancestor at level standInLevel() is paged when none is), and its cells are marked VB_REQUEST_FLAG in the cell
// table (render/gl/volume/KeptCells.h). A ray that reaches such a cell (one not yet at the termination threshold)
// sets the brick's bit in a feedback buffer, a bit per level-0 brick (shaders/volume_march.glsl, RAY_REQUESTS: both
// kernels). After the frame the bits are read back, and the next frame pages the requested bricks front to back (the
// octree's visibility order: nearest first), at most kPagesPerFrame of them. Bricks behind an opaque front are
// reached by no ray and never paged. Once no ray requests anything, every ray that is not terminated crosses only
// resident bricks, and terminated rays stop before any stand-in: the image is the octree mode's, sample for sample.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "brickstore/format/Types.h"
#include "brickstore/read/BrickStore.h"
#include "render/core/FrameStats.h"
#include "render/gl/GlObjects.h"

namespace voxbrick::render {

class VolumeProgram;

class RayRequests {
 public:
  explicit RayRequests(const Gl& gl);

  /// The most requested bricks a frame pages (its upload budget), nearest first.
  static constexpr int64_t kPagesPerFrame = 256;
  /// The most bricks the level a missing brick's stand-in is paged from may have: the finest such level.
  static constexpr int64_t kStandInLevelBricks = 512;
  /// The most level-0 bricks a store may have for rays to request them (a bit each).
  static constexpr int64_t kMaxBricks = int64_t{1} << 28;

  /// The level stand-ins are paged from when a missing brick has no resident ancestor: the finest level above 0 of
  /// at most kStandInLevelBricks bricks (the store's last if none).
  static int standInLevel(const store::BrickStore& store);
  /// Whether `store`'s level-0 brick grid fits the feedback buffer.
  static bool fits(const store::BrickStore& store);

  /// Starts a frame over `store`'s level-0 bricks: the bits cleared and bound, `program`'s grid set. The bits the
  /// last frame's rays set stay readable (requested()) until read().
  void begin(const store::BrickStore& store, const VolumeProgram& program);
  /// Whether a ray of the last frame read back requested a level-0 brick under `key` (of any level).
  bool requested(const store::BrickKey& key) const;
  /// Whether the last frame read back requested anything.
  bool any() const { return mRequestedCount > 0; }
  /// This frame's draws whose cells carry the request flag (KeptCells), replaced as a whole each frame the table
  /// changes.
  std::vector<store::BrickKey>& standIns() { return mStandIns; }
  /// After the frame: reads the count back, and the bits when it is not 0 (the frame has finished on the GPU: a copy
  /// of a word, or of a bit per brick), and counts the requested bricks and the stand-ins no ray reached into `stats`.
  void read(FrameStats& stats);
  /// Forgets the requests (a frame that failed, another store).
  void forget();

 private:
  const Gl& mGl;
  Buffer mBuffer;
  glm::ivec3 mGrid{0};
  int mBrickSize = 0;
  std::vector<uint32_t> mBits, mZero;  // the last frame's count and bits, read back; zeros to clear the buffer with
  int64_t mRequestedCount = 0;
  bool mDirty = false;  // the buffer may hold requests: cleared before the next frame
  std::vector<store::BrickKey> mStandIns;
};

}  // namespace voxbrick::render
