// The residency stage: which bricks are in the GPU atlas, paging them in from the host cache in draw order (their
// decodes handed to the cache's workers a window ahead), and the sub-block value ranges kept with each slot.
#pragma once

#include <memory>
#include <optional>
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
  /// starts now.
  void beginFrame(const std::vector<BrickDraw>& bricks);

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
  /// After a frame failed: unpins every slot (a slot whose brick failed to arrive already holds none).
  void abortFrame() { endBatch(); }

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
};

}  // namespace voxbrick::render
