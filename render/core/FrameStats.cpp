// FrameStats as JSON.
#include "render/core/FrameStats.h"

namespace voxbrick::render {

nlohmann::json FrameStats::toJson() const {
  nlohmann::json j = {{"nodes_visited", nodesVisited},
                      {"bricks_skipped_empty", bricksSkippedEmpty},
                      {"bricks_culled", bricksCulled},
                      {"bricks_outside_part", bricksOutsidePart},
                      {"bricks_drawn", bricksDrawn},
                      {"bricks_paged_in", bricksPagedIn},
                      {"bricks_evicted", bricksEvicted},
                      {"bricks_requested", bricksRequested},
                      {"bricks_untouched", bricksUntouched},
                      {"batches", batches},
                      {"slices", slices},
                      {"fragments", fragments},
                      {"samples", samples},
                      {"samples_estimated", samplesEstimated},
                      {"samples_terminated", samplesTerminated},
                      {"slab_passes", slabPasses},
                      {"sub_blocks_skipped", subBlocksSkipped},
                      {"boxes_drawn", boxesDrawn},
                      {"cell_bricks_changed", cellBricksChanged},
                      {"cells_sent", cellsSent},
                      {"bricks_coarse", bricksCoarse},
                      {"bricks_coarsened", bricksCoarsened},
                      {"bricks_per_level", bricksPerLevel},
                      {"bricks_standin", bricksStandIn},
                      {"bytes_wanted", bytesWanted},
                      {"bytes_budget", bytesBudget},
                      {"bricks_fit_coarsened", bricksFitCoarsened},
                      {"level_finest", levelFinest},
                      {"level_coarsest", levelCoarsest},
                      {"tets_drawn", tetsDrawn},
                      {"tets_skipped_empty", tetsSkippedEmpty},
                      {"tet_chunks_culled", tetChunksCulled},
                      {"tet_chunks_skipped_empty", tetChunksSkippedEmpty},
                      {"tet_chunks_read", tetChunksRead},
                      {"tet_ray_passes", tetRayPasses},
                      {"ms",
                       {{"traversal", msTraversal},
                        {"paging", msPaging},
                        {"slicing", msSlicing},
                        {"drawing", msDrawing},
                        {"readback", msReadback},
                        {"total", msTotal},
                        {"pre_integration", msPreIntegration},
                        {"sorting", msSorting},
                        {"planning", msPlanning},
                        {"setup", msSetup},
                        {"ending", msEnding},
                        {"warmup", msWarmup}}}};
  if (!fallback.empty()) j["fallback"] = fallback;
  if (plannedAhead) j["planned_ahead"] = true;
  if (!raycaster.empty()) j["raycaster"] = raycaster;
  if (!tetPart.empty()) j["tet_part"] = tetPart;
  if (!quality.is_null()) j["quality"] = quality;
  if (!interactive.is_null()) j["interactive"] = interactive;
  if (!distributed.is_null()) j["distributed"] = distributed;
  return j;
}

}  // namespace voxbrick::render
