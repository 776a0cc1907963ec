// One sort-last frame across the ranks (RankRenderer.h).
#include "distributed/RankRenderer.h"

#include <chrono>
#include <sstream>

#include "distributed/Cluster.h"
#include "render/core/PartialFrame.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::distributed {

RankRenderer::RankRenderer(MPI_Comm comm, render::RenderEngine& engine, RankRendererOptions options)
    : mComm(comm), mEngine(engine), mOptions(options) {
  MPI_Comm_rank(comm, &mRank);
  MPI_Comm_size(comm, &mSize);
}

const render::SortLastParts& RankRenderer::partition(const std::shared_ptr<const render::Dataset>& dataset) {
  for (auto it = mPartitions.begin(); it != mPartitions.end();) {
    it = it->second.first.expired() ? mPartitions.erase(it) : std::next(it);
  }
  auto found = mPartitions.find(dataset.get());
  if (found != mPartitions.end()) return *found->second.second;
  auto& entry = mPartitions[dataset.get()];
  entry = {dataset, render::driverFor(*dataset).partition(*dataset, mSize)};
  return *entry.second;
}

image::ImageF RankRenderer::render(const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene,
                                   render::FrameStats* stats, nlohmann::json* distributedJson,
                                   const render::FrameOptions& options) {
  if (!dataset) throw render::RenderInputError("no dataset");
  if (!render::driverFor(*dataset).sortsLast())
    throw render::RenderInputError("the distributed mode draws grids (brick stores) only; '" + dataset->name() +
                                   "' is a " + std::string(dataset->kind()));
  const render::SortLastParts& parts = partition(dataset);
  const std::vector<int> order = parts.frontToBack(scene);
  render::FrameOptions partOptions = options;
  partOptions.part = parts.boxes()[size_t(mRank)];
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
    partial = {scene.width, scene.height, std::vector<float>(size_t(scene.width) * size_t(scene.height) * 4, 0.0f)};
  }
  const double drawMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - drawStart).count();
  CompositeStats composited;
  image::Image8 whole = compositeFinished(mComm, partial, order, scene, mOptions.composite, &composited);
  // Every rank's figures to rank 0 (and to all: one small gather).
  const store::CacheStats cache = dataset->cacheStats();
  std::ostringstream record;
  record << drawMs << " " << own.msPaging << " " << composited.ms << " " << composited.bytesSent << " "
         << composited.bytesReceived << " " << cache.peakResidentBytes << " " << cache.budgetBytes << " "
         << own.bricksDrawn << " " << mEngine.peakGpuBytes() << " " << failure;
  const auto records = allGather(mComm, record.str(), mOptions.composite.timeoutSeconds);
  if (failed) std::rethrow_exception(failed);
  if (mRank != 0) return {};
  nlohmann::json perRank = nlohmann::json::array();
  uint64_t totalBytes = 0;
  for (size_t r = 0; r < records.size(); ++r) {
    std::istringstream in(records[r]);
    double draw = 0, paging = 0, compositeMs = 0;
    uint64_t sent = 0, received = 0, peakHost = 0, budget = 0, peakGpu = 0;
    int64_t bricks = 0;
    in >> draw >> paging >> compositeMs >> sent >> received >> peakHost >> budget >> bricks >> peakGpu;
    std::string error;
    std::getline(in >> std::ws, error);
    if (!error.empty()) throw render::RenderError("rank " + std::to_string(r) + " could not draw its part: " + error);
    totalBytes += sent;
    perRank.push_back({{"rank", r},
                       {"drawing_ms", draw},
                       {"paging_ms", paging},
                       {"compositing_ms", compositeMs},
                       {"bytes_sent", sent},
                       {"bytes_received", received},
                       {"bricks_drawn", bricks},
                       {"host_cache_peak_bytes", peakHost},
                       {"host_cache_budget_bytes", budget},
                       {"gpu_peak_bytes", peakGpu}});
  }
  if (distributedJson) {
    *distributedJson = {{"ranks", mSize},
                        {"encoding", pixelEncodingName(mOptions.composite.encoding)},
                        {"front_to_back", order},
                        {"compositing_ms", composited.ms},
                        {"bytes_exchanged", totalBytes},
                        {"per_rank", perRank}};
  }
  if (stats) *stats = own;
  return image::toImageF(whole);  // finished by each rank over the background, 8-bit (exactly what output keeps)
}

}  // namespace voxbrick::distributed
