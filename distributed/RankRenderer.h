// One sort-last frame across a group of ranks (Cluster.h's RankGroup): every member draws its part of a dataset with
// its own RenderEngine (FrameOptions::part or meshPart, the parts its kind's driver splits it into, one per member),
// and the partial frames are composited in the parts' front-to-back order by radix-k (Compositor.h), each member
// finishing its own region over the scene's background into rank 0's 8-bit frame. Collective: every member calls
// render() with the same group, dataset and scene.
#pragma once

#include <mpi.h>

#include <map>
#include <memory>

#include <nlohmann/json.hpp>

#include "distributed/Cluster.h"
#include "distributed/Compositor.h"
#include "image/Image.h"
#include "render/core/Dataset.h"
#include "render/core/FrameRenderer.h"
#include "render/core/FrameStats.h"
#include "render/core/Scene.h"
#include "render/engine/DatasetDriver.h"
#include "render/engine/RenderEngine.h"

namespace voxbrick::distributed {

struct RankRendererOptions {
  CompositeOptions composite;  ///< encoding and the deadline of every transfer
};

class RankRenderer {
 public:
  RankRenderer(MPI_Comm comm, render::RenderEngine& engine, RankRendererOptions options = {});

  /// Draws this rank's part of `scene` (the part of its index among `group`'s members) and composites over the
  /// group. Rank 0 returns the finished frame and, in `stats`, its own frame statistics with `distributed` set (the
  /// members drawing, the lost ranks given in `lost`, each member's drawing ms, estimated samples, paging and host
  /// cache peak, the compositing ms and bytes each sent and received: gathered to rank 0 only), except the frame's
  /// cost, which is the whole frame's: `samplesEstimated` every member's together, `msTotal` (and an interactive
  /// frame's `actual_ms`) rank 0's from the start of its drawing to the composited frame, so that a rate measured
  /// from them is the group's. Other ranks return an empty image.
  /// An interactive scene is drawn reduced on every rank with the same choice, composited at the reduced size and
  /// scaled up once, on rank 0, to the scene's size times `options.outputScale` (a video stream's smaller size, as
  /// one process returns it): `options.rateSamplesPerMs`, `fixedMs` and `outputScale` must be the same on every rank
  /// (the caller broadcasts rank 0's). With `frame8`, rank 0's exact frame goes there as the compositor made it, 8 bits, and
  /// the float image returned is empty (an interactive frame, scaled up in floats, is still returned as floats).
  /// Throws RenderInputError for a kind whose driver does not sort last, PeerError naming a rank that failed or
  /// passed the deadline, and the engine's errors.
  image::ImageF render(const RankGroup& group, const std::shared_ptr<const render::Dataset>& dataset,
                       const render::Scene& scene, render::FrameStats* stats, const render::FrameOptions& options = {},
                       const nlohmann::json& lost = nlohmann::json::array(), image::Image8* frame8 = nullptr);

  /// The dataset's parts, one per member of a group of `parts` ranks (DatasetDriver::partition, computed once per
  /// dataset and count).
  const render::SortLastParts& partition(const std::shared_ptr<const render::Dataset>& dataset, int parts);

 private:
  MPI_Comm mComm;
  render::RenderEngine& mEngine;
  RankRendererOptions mOptions;
  int mRank = 0;
  std::map<std::pair<const render::Dataset*, int>,
           std::pair<std::weak_ptr<const render::Dataset>, std::shared_ptr<const render::SortLastParts>>>
      mPartitions;
};

}  // namespace voxbrick::distributed
