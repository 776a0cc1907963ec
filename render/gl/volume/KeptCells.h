// The frame ray caster's cell table kept from frame to frame (render/gl/volume/CellTable.h): for a frame of one batch
// (every brick in the atlas at once, no part), the table changes only where the frame's bricks differ from the last
// frame's: a brick gone clears its cells, a brick added (or moved to another slot, or drawn from another stand-in)
// marks its own, and only the changed blocks get new leaps and are sent. A frame that draws what the last one drew,
// every brick where it was (Residency::unchanged), looks up no brick at all. So a warm frame's work on the CPU follows
// what changed, not the number of bricks.
//
// The table marks a brick's cells whatever the view: the frame of batches leaves out boxes no global plane crosses,
// which no sample of this view lies in; marked, the ray steps through them instead of leaping, and takes the same
// samples. It depends on the plan only through the cell grid, the sub-block size and the classification
// (FramePlan::classification: which sub-blocks are empty), and is rebuilt when one of those changes.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "render/core/FrameStats.h"
#include "render/gl/Checkpoints.h"
#include "render/gl/volume/CellTable.h"
#include "render/gl/volume/RayRequests.h"
#include "render/gl/volume/Residency.h"
#include "render/volume/FramePlan.h"
#include "render/volume/SubBlocks.h"

namespace voxbrick::render {

class KeptCells {
 public:
  /// Whether `plan` may be drawn from a kept table by `residency`: one batch, no part.
  static bool fits(const FramePlan& plan, const Residency& residency);

  /// Brings `cells` up to `plan` (which fits()), paging the bricks that are not resident, and binds the table.
  /// Fills the paging counters of `stats`, boxesDrawn, subBlocksSkipped and cellsSent. Returns whether any cell has
  /// something to draw. Polls `checkpoints` between bricks.
  /// With `requests` (ray-driven residency, render/gl/volume/RayRequests.h), only the bricks that are resident or
  /// that the last frame's rays requested (at most RayRequests::kPagesPerFrame of them, front to back) are drawn as
  /// themselves; the others are drawn from a resident ancestor, whole, their cells flagged for the rays to request
  /// them.
  bool update(const FramePlan& plan, Residency& residency, CellTable& cells, FrameStats& stats,
              const Checkpoints& checkpoints, RayRequests* requests = nullptr);
  /// Forgets the table: the next update() builds it anew (after a frame of batches, or a frame that failed).
  void forget() { mValid = false; }

 private:
  struct Record {
    uint32_t standIn = 0;
    glm::ivec4 payload{0};
    int64_t boxes = 0, subBlocksSkipped = 0;
    uint64_t frame = 0;  // the last frame that drew it
  };
  struct Pending {
    BrickDraw draw;  // with the stand-in this frame draws it from
    bool flagged;    // drawn from a stand-in for the rays to request (whole: no sub-block left out)
    Residency::Resident resident;
    glm::ivec4 payload;
  };
  void clearRecords();

  std::unordered_map<store::BrickKey, Record> mRecords;  // by BrickDraw::key: the bricks the table holds
  int mSubBlock = -1;
  ClassificationKey mClassification;
  uint64_t mFrame = 0;
  int64_t mBoxes = 0, mSubBlocksSkipped = 0, mDrawing = 0;  // over the records; mDrawing: those with boxes
  bool mValid = false;
  bool mRays = false;  // whether the table was last brought up to date with ray-driven residency
  std::vector<Pending> mPending;
  std::vector<VoxelSpan> mSpans;
  std::vector<store::BrickKey> mWanted;  // ray-driven residency: the requested bricks this frame pages
};

}  // namespace voxbrick::render
