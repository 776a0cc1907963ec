// One sort-last frame across the ranks (RankRenderer.h).
#include "distributed/RankRenderer.h"

#include <algorithm>
#include <chrono>
#include <sstream>

#include "distributed/Cluster.h"
#include "render/core/Interactive.h"
#include "render/core/PartialFrame.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::distributed {

RankRenderer::RankRenderer(MPI_Comm comm, render::RenderEngine& engine, RankRendererOptions options)
    : mComm(comm), mEngine(engine), mOptions(options) {
  MPI_Comm_rank(comm, &mRank);
}

const render::SortLastParts& RankRenderer::partition(const std::shared_ptr<const render::Dataset>& dataset, int parts) {
  for (auto it = mPartitions.begin(); it != mPartitions.end();) {
    it = it->second.first.expired() ? mPartitions.erase(it) : std::next(it);
  }
  auto found = mPartitions.find({dataset.get(), parts});
  if (found != mPartitions.end()) return *found->second.second;
  auto& entry = mPartitions[{dataset.get(), parts}];
  entry = {dataset, render::driverFor(*dataset).partition(*dataset, parts)};
  return *entry.second;
}

image::ImageF RankRenderer::render(const RankGroup& group, const std::shared_ptr<const render::Dataset>& dataset,
                                   const render::Scene& scene, render::FrameStats* stats,
                                   const render::FrameOptions& options, const nlohmann::json& lost,
                                   image::Image8* frame8) {
  if (!dataset) throw render::RenderInputError("no dataset");
  if (!render::driverFor(*dataset).sortsLast())
    throw render::RenderInputError("the distributed mode draws grids and tetrahedral meshes only; '" + dataset->name() +
                                   "' is a " + std::string(dataset->kind()) +
                                   ", which its driver does not split into parts");
  const int index = group.indexOf(mRank);
  if (index < 0) throw std::invalid_argument("rank " + std::to_string(mRank) + " is not a member of the group");
  const render::SortLastParts& parts = partition(dataset, group.size());
  const std::vector<int> order = parts.frontToBack(scene);  // the parts, nearest first: member i draws part i
  render::FrameOptions partOptions = options;
  parts.select(index, partOptions);
  partOptions.keepReducedSize = true;  // an interactive frame is composited at the size it was drawn
  render::FrameStats own;
  auto drawStart = std::chrono::steady_clock::now();
  // A rank whose drawing fails still takes its part in compositing (with nothing drawn), so that every rank stays in
  // step; rank 0 reports the failure, naming the rank, once the frame's exchanges are over.
  image::ImageF partial;
  std::string failure;
  std::exception_ptr failed;
  try {
    partial = mEngine.render(dataset, scene, &own, partOptions);
  } catch (const std::exception& error) {
    failure = error.what();
    failed = std::current_exception();
  }
  if (failed || partial.rgba.empty()) {
    // Nothing drawn, at the scene's size. An interactive frame's parts are composited at its rung's size (the same
    // choice on every rank); a rank that failed before drawing one is then refused by the compositor on its peers,
    // which names it.
    partial = {scene.width, scene.height, std::vector<float>(size_t(scene.width) * size_t(scene.height) * 4, 0.0f)};
  }
  const double drawMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - drawStart).count();
  CompositeOptions compositeOptions = mOptions.composite;
  compositeOptions.tag = group.tag(kCompositeTags);
  compositeOptions.ranks = group.members;
  compositeOptions.root = 0;
  // Only the pixels the part's box covers are read (a rank's part covers a share of the frame). A scene whose
  // camera cannot project (its drawing failed already) reads the whole frame, so that this rank stays in step.
  try {
    compositeOptions.footprint = parts.footprint(index, scene, partial.width, partial.height, failed ? nullptr : &own);
  } catch (const std::exception&) {
    compositeOptions.footprint = render::PixelRect{0, 0, partial.width, partial.height};
  }
  const render::PixelRect& given = *compositeOptions.footprint;
  const long long footprintPixels =  // within the frame (a wide one is read as whole rows: pixels_handled says)
      render::PixelRect{std::max(given.x0, 0), std::max(given.y0, 0), std::min(given.x1, partial.width),
                        std::min(given.y1, partial.height)}
          .pixels();
  CompositeStats composited;
  // Finished to 8 bits by each member over the background, its region straight into rank 0's frame; an interactive
  // frame drawn reduced, or returned smaller than its scene (FrameOptions::outputScale), is composited at its drawn
  // size as floats, finished and scaled once on rank 0, as one process scales its reduced frame.
  const bool smaller = scene.interactive && options.outputScale < 1;
  const int outputWidth = smaller ? render::scaledSide(scene.width, options.outputScale) : scene.width;
  const int outputHeight = smaller ? render::scaledSide(scene.height, options.outputScale) : scene.height;
  const bool reduced = partial.width != scene.width || partial.height != scene.height || smaller;
  image::Image8 finished8;
  image::ImageF whole;
  if (reduced)
    whole = composite(group.comm, std::move(partial), order, compositeOptions, &composited);
  else
    compositeFinished(group.comm, partial, order, scene, finished8, compositeOptions, &composited);
  // Every member's figures to rank 0 only.
  const store::CacheStats cache = dataset->cacheStats();
  std::ostringstream record;
  record << drawMs << " " << own.msPaging << " " << composited.ms << " " << composited.bytesSent << " "
         << composited.bytesReceived << " " << cache.peakResidentBytes << " " << cache.budgetBytes << " "
         << own.bricksDrawn << " " << own.bricksOutsidePart << " " << mEngine.peakGpuBytes() << " "
         << footprintPixels << " " << composited.pixelsHandled << " " << own.tetsDrawn << " " << own.samplesEstimated
         << " " << failure;
  const auto records = gatherRecords(group, record.str(), mOptions.composite.timeoutSeconds);
  if (failed) std::rethrow_exception(failed);
  if (mRank != 0) return {};
  nlohmann::json perRank = nlohmann::json::array();
  uint64_t totalBytes = 0;
  double totalSamples = 0;
  for (size_t i = 0; i < records.size(); ++i) {
    std::istringstream in(records[i]);
    double draw = 0, paging = 0, compositeMs = 0, samples = 0;
    uint64_t sent = 0, received = 0, peakHost = 0, budget = 0, peakGpu = 0, footprint = 0, handled = 0;
    int64_t bricks = 0, outside = 0, tets = 0;
    in >> draw >> paging >> compositeMs >> sent >> received >> peakHost >> budget >> bricks >> outside >> peakGpu >>
        footprint >> handled >> tets >> samples;
    std::string error;
    std::getline(in >> std::ws, error);
    const int rank = group.members[i];
    if (!error.empty())
      throw render::RenderError("rank " + std::to_string(rank) + " could not draw its part: " + error);
    totalBytes += sent;
    totalSamples += samples;
    perRank.push_back({{"rank", rank},
                       {"part", i},
                       {"drawing_ms", draw},
                       {"paging_ms", paging},
                       {"compositing_ms", compositeMs},
                       {"bytes_sent", sent},
                       {"bytes_received", received},
                       {"footprint_pixels", footprint},
                       {"pixels_handled", handled},
                       {"bricks_drawn", bricks},
                       {"tets_drawn", tets},
                       {"samples_estimated", samples},
                       {"bricks_outside_part", outside},
                       {"host_cache_peak_bytes", peakHost},
                       {"host_cache_budget_bytes", budget},
                       {"gpu_peak_bytes", peakGpu}});
  }
  std::vector<int> nearestFirst;  // the members drawing the parts, nearest first
  for (int part : order) nearestFirst.push_back(group.members[size_t(part)]);
  own.distributed = {{"ranks", group.size()},
                     {"members", group.members},
                     {"epoch", group.epoch},
                     {"lost_ranks", lost},
                     {"encoding", pixelEncodingName(mOptions.composite.encoding)},
                     {"front_to_back", nearestFirst},
                     {"composited_width", reduced ? whole.width : finished8.width},
                     {"composited_height", reduced ? whole.height : finished8.height},
                     {"compositing_ms", composited.ms},
                     {"bytes_exchanged", totalBytes},
                     {"per_rank", perRank}};
  // The frame as a whole, as one process's stats give it (and as the server's rate of the session is measured: the
  // frame's samples over its time): every member's estimated samples, and rank 0's time from the start of its
  // drawing to the composited frame. Rank 0's own drawing is in per_rank.
  own.samplesEstimated = totalSamples;
  own.msTotal = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - drawStart).count();
  if (own.interactive.is_object()) own.interactive["actual_ms"] = own.msTotal;
  if (stats) *stats = own;
  if (!reduced && frame8) {
    *frame8 = std::move(finished8);
    return {};
  }
  if (!reduced) return image::toImageF(finished8);  // exactly the 8-bit values the frame keeps
  image::ImageF finished = render::finishPartial(whole, scene);
  return render::scaleBilinear(finished, outputWidth, outputHeight);
}

}  // namespace voxbrick::distributed
