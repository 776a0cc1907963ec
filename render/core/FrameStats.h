// What one frame did (every frame reports it), whichever renderer drew it. GL-free.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/core/Camera.h"

namespace voxbrick::render {

/// Milliseconds from `start` to now on the steady clock: the unit of every time in FrameStats.
inline double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

struct FrameStats {
  int64_t nodesVisited = 0;
  int64_t bricksSkippedEmpty = 0;
  int64_t bricksCulled = 0;
  int64_t bricksOutsidePart = 0;  ///< sort-last: level-0 bricks of other ranks' parts, never walked into
  int64_t bricksDrawn = 0;        ///< bricks drawn, of every level
  int64_t bricksCoarse = 0;       ///< of those, bricks of a coarser level standing for level 0 (Scene::lod)
  int64_t bricksCoarsened = 0;    ///< level-0 bricks the coarse ones stood for
  /// Coarse-to-fine streaming (FrameOptions::standIns): bricks drawn from a resident ancestor because they were not
  /// yet resident themselves (they are being paged for a later frame). 0: the frame is exactly the scene's.
  int64_t bricksStandIn = 0;
  std::vector<int64_t> bricksPerLevel;  ///< bricks drawn of each pyramid level
  /// The fit of the frame's bricks to its budget (FrameOptions::fitBudget): the bytes the level choice by screen-space
  /// error wanted in the atlas's format, the atlas's bytes, and the bricks the fit took away by drawing parents
  /// instead of their children (0 when the set fitted as chosen).
  int64_t bytesWanted = 0, bytesBudget = 0, bricksFitCoarsened = 0;
  int levelFinest = 0, levelCoarsest = 0;  ///< the finest and coarsest pyramid levels drawn
  int64_t bricksPagedIn = 0;               ///< uploaded into the atlas this frame
  int64_t bricksEvicted = 0;               ///< replaced in the atlas this frame
  /// Ray-driven residency (Scene::residency rays): bricks the rays reached this frame and did not find resident (read
  /// back from the march's feedback buffer), and bricks the octree walk found visible that are still drawn from a
  /// stand-in because no ray has reached them (what the octree mode would have paged and this mode has not). 0 in
  /// the octree mode.
  int64_t bricksRequested = 0, bricksUntouched = 0;
  double samplesEstimated = 0;  ///< the frame's cost as estimated before drawing (FramePlan::estimatedSamples)
  int64_t batches = 0;          ///< draw batches (more than one when the atlas cannot hold the frame's bricks)
  /// A ray-cast grid frame: the kernel that drew it, "fragment" or "compute" (Scene::raycaster, auto resolved); empty
  /// otherwise.
  std::string raycaster;
  int64_t slices = 0;     ///< brick-plane polygons submitted (slicing and slabs; the ray caster has none)
  int64_t fragments = 0;  ///< volume fragments started: slices (GL_SAMPLES_PASSED) or slab fragments
  int64_t samples = 0;    ///< volume samples taken: one per slice fragment, several per slab fragment
  /// Texture slabs: samples a fragment left when its own opacity reached the termination threshold (an upper bound:
  /// planes of its range, before the ownership test). Fragments the silhouette map rejected are not started at all.
  int64_t samplesTerminated = 0;
  int64_t slabPasses = 0;        ///< texture slabs: draws of one slab each
  int64_t subBlocksSkipped = 0;  ///< sub-blocks of drawn bricks left out as empty (Scene::subBlock)
  int64_t boxesDrawn = 0;        ///< boxes sliced: bricks (stand-ins merged), or with sub-blocks the boxes drawn
  /// The frame ray caster's cell table when it is kept between frames (render/gl/volume/KeptCells.h): the bricks
  /// whose cells this frame changed (every brick when it was built anew, 0 when it was drawn as it stood) and the
  /// cells sent to the GPU. A frame of batches fills each batch's table anew: -1 and every cell of each batch.
  int64_t cellBricksChanged = 0, cellsSent = 0;
  /// Wall time of each phase on the calling thread. Drawing ends with a glFinish, but with several batches a
  /// batch's GPU work may instead be waited for by the next batch's uploads and show up as paging.
  double msTraversal = 0, msPaging = 0, msSlicing = 0, msDrawing = 0, msReadback = 0, msTotal = 0;
  /// A grid frame's CPU time besides those phases: planning after the walk (the estimate, the plan's counts), setting
  /// up before the pass (the frame's residency stamps, the target cleared, the tables and programs set), and
  /// ending after the readback (residency and counters), so that where a warm frame's time goes adds up.
  double msPlanning = 0, msSetup = 0, msEnding = 0;
  /// One-time work the frame set off on its context (RenderEngine): a renderer made for the dataset (its atlas
  /// allocated, its programs built; before msTotal's clock starts) and programs built for a variant drawn the first
  /// time (inside the phases, so within msTotal). 0 for a frame drawn by a warm context. JSON "ms": "warmup".
  double msWarmup = 0;
  /// Planned while the GPU drew the frame before it (FrameRenderer::renderSequence8); JSON "planned_ahead" when true.
  bool plannedAhead = false;
  int64_t tetsDrawn = 0;         ///< tetrahedra drawn (a mesh frame)
  int64_t tetsSkippedEmpty = 0;  ///< tetrahedra the transfer function makes transparent over their value range
  /// A paged mesh (TetMeshSource): chunks outside the view frustum, chunks the transfer function makes transparent
  /// over their value range, and chunks read from the store for this frame (0 when its working set was kept).
  int64_t tetChunksCulled = 0, tetChunksSkippedEmpty = 0, tetChunksRead = 0;
  double msSorting = 0;  ///< a mesh frame's visibility sort
  /// A ray-cast mesh frame's entry passes (render/gl/tets/TetRayCaster.h), each followed by a ray pass but the last,
  /// which found no entry: 2 for a convex mesh. 0 when the frame was projected.
  int64_t tetRayPasses = 0;
  /// A mesh part's frame (FrameOptions::meshPart): how it was clipped to the part's box, "raycast" (each ray's walk
  /// integrated only inside the box) or "projected" (each projected tet's fragment's segment cut to the box); empty
  /// for a whole frame and for a part with nothing to draw. JSON "tet_part" when set.
  std::string tetPart;
  double msPreIntegration = 0;  ///< building the pre-integration table (0 when the last frame's was current)
  /// Why the frame was not drawn as the scene asked (the ray caster's cell table too large for the volume: texture
  /// slabs instead); empty when it was. The CLI prints it and the JSON has it as "fallback".
  std::string fallback;
  /// A scene with a quality target: what it chose (QualityChoice::toJson); null otherwise.
  nlohmann::json quality;
  /// An interactive frame (Scene::interactive): what it chose to fit its time budget (InteractiveChoice::toJson,
  /// plus "actual_ms"); null otherwise. msTotal and the other counts are those of the reduced drawing.
  nlohmann::json interactive;
  /// A sort-last frame across MPI ranks (distributed/RankRenderer.h): the ranks drawing, those lost, the order and
  /// the compositing; null otherwise.
  nlohmann::json distributed;
  /// A grid part's frame (FrameOptions::part): the box, in the renderers' local frame, of the bricks it drew (min
  /// above max when it drew none); none for whole frames and other kinds. The part's footprint shrinks to it
  /// (SortLastParts::footprint). Not in the JSON.
  std::optional<Box> drawnBox;

  /// The statistics as a JSON object (snake_case keys, times under "ms"), to which callers may add their own keys.
  nlohmann::json toJson() const;
};

}  // namespace voxbrick::render
