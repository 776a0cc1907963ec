// What one frame did (every frame reports it), whichever renderer drew it. GL-free.
#pragma once

#include <cstdint>

#include <nlohmann/json.hpp>

namespace voxbrick::render {

struct FrameStats {
  int64_t nodesVisited = 0;
  int64_t bricksSkippedEmpty = 0;
  int64_t bricksCulled = 0;
  int64_t bricksDrawn = 0;
  int64_t bricksPagedIn = 0;   ///< uploaded into the atlas this frame
  int64_t bricksEvicted = 0;   ///< replaced in the atlas this frame
  int64_t batches = 0;         ///< draw batches (more than one when the atlas cannot hold the frame's bricks)
  int64_t slices = 0;          ///< brick-plane polygons submitted
  int64_t fragments = 0;       ///< fragments shaded (GL_SAMPLES_PASSED): one volume sample each
  int64_t subBlocksSkipped = 0;  ///< sub-blocks of drawn bricks left out as empty (Scene::subBlock)
  int64_t boxesDrawn = 0;        ///< boxes sliced: bricks, or with sub-blocks the boxes bricks are drawn as
  /// Wall time of each phase on the calling thread. Drawing ends with a glFinish, but with several batches a
  /// batch's GPU work may instead be waited for by the next batch's uploads and show up as paging.
  double msTraversal = 0, msPaging = 0, msSlicing = 0, msDrawing = 0, msReadback = 0, msTotal = 0;

  /// The statistics as a JSON object (snake_case keys, times under "ms"), to which callers may add their own keys.
  nlohmann::json toJson() const;
};

}  // namespace voxbrick::render
