// One sort-last frame across the ranks of a communicator: every rank draws its part of a dataset with its own
// RenderEngine (FrameOptions::part, the parts its kind's driver splits it into, one per rank), the partial
// frames are composited in the parts' front-to-back order (Compositor.h), and rank 0 finishes the frame over the
// scene's background. Collective: every rank calls render() with the same dataset and scene.
#pragma once

#include <mpi.h>

#include <map>
#include <memory>

#include <nlohmann/json.hpp>

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

  /// Draws this rank's part of `scene` and composites. Rank 0 returns the finished frame and, in `stats`, its own
  /// frame statistics with a "distributed" object added to `distributedJson` (each rank's drawing ms, paging and
  /// host cache peak, the compositing ms and bytes each rank sent and received); other ranks return an empty image.
  /// An interactive scene is drawn reduced on every rank with the same choice: `options.rateSamplesPerMs` and
  /// `fixedMs` must be the same on every rank (the caller broadcasts rank 0's). Throws RenderInputError for a kind
  /// whose driver does not sort last, PeerError naming a rank that failed or passed the deadline, and the
  /// engine's errors.
  image::ImageF render(const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene,
                       render::FrameStats* stats, nlohmann::json* distributedJson,
                       const render::FrameOptions& options = {});

  /// The dataset's parts, one per rank (DatasetDriver::partition, computed once per dataset).
  const render::SortLastParts& partition(const std::shared_ptr<const render::Dataset>& dataset);

 private:
  MPI_Comm mComm;
  render::RenderEngine& mEngine;
  RankRendererOptions mOptions;
  int mRank = 0, mSize = 1;
  std::map<const render::Dataset*,
           std::pair<std::weak_ptr<const render::Dataset>, std::shared_ptr<const render::SortLastParts>>>
      mPartitions;
};

}  // namespace voxbrick::distributed
