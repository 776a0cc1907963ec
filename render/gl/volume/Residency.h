// The residency stage: which bricks are in the GPU atlas, paging them in from the host cache in draw order (their
// decodes handed to the cache's workers a window ahead), and the sub-block value ranges kept with each slot.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "brickstore/read/BrickCache.h"
#include "render/core/FrameStats.h"
#include "render/gl/volume/BrickAtlas.h"
#include "render/volume/SubBlocks.h"
#include "render/volume/Traversal.h"

namespace voxbrick::render {

class Residency {
 public:
  /// The most atlas slots a frame of `store` can use: one per level-0 brick (a frame draws at most one brick per
  /// level-0 region, whatever its levels), capped.
  static int usefulSlots(const store::BrickStore& store);
  /// The bytes an atlas for `store` takes under `gpuBudgetBytes` (at most the budget), texture and staging,
  /// with `uploads` resolved (Direct or Staged).
  static size_t atlasBytes(const store::BrickStore& store, size_t gpuBudgetBytes, AtlasFormat format,
                           AtlasUploads uploads);

  /// An atlas of `gpuBudgetBytes` in `format` for the bricks of `cache`'s store; the context must be current.
  Residency(const GlContext& context, std::shared_ptr<store::BrickCache> cache, size_t gpuBudgetBytes,
            AtlasFormat format, AtlasUploads uploads = AtlasUploads::Auto,
            AtlasBricking bricking = AtlasBricking::Single);

  /// Coarse-to-fine streaming, before beginFrame: every brick of `bricks` that is neither in the atlas nor in the
  /// host cache is drawn from its nearest ancestor that is (up to level `coarsest`, whose brick is read now if no
  /// ancestor is ready), and queued, in draw order, for the cache's workers to decode for a later frame. So the
  /// frame never waits for the disk but for at most one brick of the coarsest level, and leaves no hole. All the
  /// children of a node drawn from the same ancestor become the node's one box. Returns how many bricks stand-ins
  /// replaced.
  int64_t standIn(std::vector<BrickDraw>& bricks, int coarsest);

  /// Starts a frame that will acquire the sources of `bricks` in this order: decoding of the ones not resident
  /// starts now. When the last frame ended (endFrame) with the same draws (keys and stand-ins, in any order) and no
  /// slot has changed hands since, nothing is looked up: unchanged() says so, and every brick of the frame is
  /// resident where it was.
  /// `prefetch` false (ray-driven residency, render/gl/volume/RayRequests.h): no brick is decoded ahead, since not
  /// every brick drawn is to be paged; prefetch() names those that are.
  void beginFrame(const std::vector<BrickDraw>& bricks, bool prefetch = true);
  /// Hands `keys` to the cache's workers to decode, in this order, for acquire() to page soon.
  void prefetch(std::span<const store::BrickKey> keys) { mCache->prefetch(keys); }
  /// Whether brick `key` is in the atlas now.
  bool resident(const store::BrickKey& key) const { return mAtlas.slots().resident(key); }
  /// Whether this frame draws what the last frame drew, every brick in the slot it had then (beginFrame).
  bool unchanged() const { return mUnchanged; }
  /// Ends a frame that was drawn: what unchanged() compares the next frame with (only a frame of one batch: one that
  /// needed no more slots than the atlas has).
  void endFrame();

  /// A brick in the atlas, pinned until endBatch().
  struct Resident {
    AtlasSlot slot;
    glm::ivec3 origin;             ///< texel of the slot's first (border) sample
    int orientation;               ///< the brick's axis rotation in its slot (orientVoxel)
    const SubBlockRanges* ranges;  ///< the brick's sub-block ranges at the frame's sub-block size (empty if 0)
  };
  /// The brick `key` in the atlas, paged in if it was not, with its sub-block ranges for `subBlock` (0: none);
  /// nothing when every slot is pinned by the current batch (draw it, endBatch(), and ask again).
  std::optional<Resident> acquire(const store::BrickKey& key, int subBlock, FrameStats& stats);
  /// Ends a batch: its slots may be replaced again.
  void endBatch() { mAtlas.slots().unpinAll(); }
  /// After a frame failed: unpins every slot (a slot whose brick failed to arrive already holds none); the next
  /// frame is not unchanged().
  void abortFrame() {
    endBatch();
    mEnded = false;
  }

  const BrickAtlas& atlas() const { return mAtlas; }
  const store::BrickStore& store() const { return *mCache->store(); }
  const store::BrickCache& cache() const { return *mCache; }

 private:
  void prefetchUpTo(size_t end);

  std::shared_ptr<store::BrickCache> mCache;
  BrickAtlas mAtlas;
  std::vector<SubBlockRanges> mSlotRanges;  // per atlas slot: sub-block ranges of the brick it holds
  std::vector<store::BrickKey> mToPage;     // this frame's bricks that were not resident, in draw order
  size_t mPrefetched = 0, mPaged = 0;
  // What unchanged() compares: per level and brick (x fastest), the last frame that drew it and its stand-in then;
  // how many bricks the last frame drew, and the slots' generation when it ended.
  struct Drawn {
    uint32_t frame = 0, standIn = 0;
  };
  std::vector<std::vector<Drawn>> mDrawn;
  uint32_t mFrame = 0;
  size_t mLastDraws = 0;
  uint64_t mEndGeneration = 0;
  bool mEnded = false, mUnchanged = false;
};

}  // namespace voxbrick::render
