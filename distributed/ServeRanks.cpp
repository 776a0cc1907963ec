// Rank 0's frame leader and frame source, and the workers' loop of `serve --mpi` (ServeRanks.h).
#include "distributed/ServeRanks.h"

#include <chrono>
#include <map>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "distributed/Cluster.h"
#include "render/core/RenderErrors.h"
#include "render/engine/DatasetDriver.h"
#include "render/engine/Datasets.h"

namespace voxbrick::distributed {
namespace {

// The datasets a worker holds, by name, reopened when their files change; one host budget shared equally.
class WorkerDatasets {
 public:
  WorkerDatasets(std::filesystem::path directory, size_t cacheBytes)
      : mDirectory(std::move(directory)), mCacheBytes(cacheBytes) {}
  /// The dataset `name`, and in `identity` its datasetIdentity (computed once, for the reopen check and the
  /// agreement with rank 0).
  std::shared_ptr<const render::Dataset> open(const std::string& name, std::string& identity) {
    const auto path = mDirectory / name;
    identity = datasetIdentity(path);
    if (auto it = mOpen.find(name); it != mOpen.end()) {
      if (it->second.second == identity) return it->second.first;
      mOpen.erase(it);
    }
    const size_t share = mCacheBytes / (mOpen.size() + 1);
    auto dataset = render::openDataset(name, path, share);
    for (auto& [other, open] : mOpen) open.first->setCacheBudget(share);
    mOpen[name] = {dataset, identity};
    return dataset;
  }

 private:
  std::filesystem::path mDirectory;
  size_t mCacheBytes;
  std::map<std::string, std::pair<std::shared_ptr<const render::Dataset>, std::string>> mOpen;
};

render::FrameOptions frameOptionsOf(const nlohmann::json& command) {
  render::FrameOptions options;
  options.standIns = command.value("stand_ins", false);
  options.maxSamples = command.value("max_samples", 0.0);
  options.rateSamplesPerMs = rateOrCheapest(command.value("rate", 0.0));
  options.fixedMs = command.value("fixed_ms", 0.0);
  return options;
}

}  // namespace

FrameLeader::FrameLeader(MPI_Comm comm, ServeRankOptions options) : mComm(comm), mOptions(std::move(options)) {}

image::ImageF FrameLeader::frame(RankRenderer& renderer, double recentRate,
                                 const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene,
                                 render::FrameStats* stats, const render::FrameOptions& options) {
  std::lock_guard lock(mMutex);
  if (mLost) throw render::RenderError("the distributed mode stopped earlier: " + *mLost + "; restart the server");
  const double timeout = mOptions.frames.composite.timeoutSeconds;
  // Every rank draws the same interactive rung: chosen by rank 0's rate (none known yet: the cheapest), sent in the
  // frame's command with its deadline.
  const double rate = rateOrCheapest(options.rateSamplesPerMs > 0 ? options.rateSamplesPerMs : recentRate);
  nlohmann::json command = {{"op", "frame"},
                            {"name", dataset->name()},
                            {"scene", scene.toJson()},
                            {"stand_ins", options.standIns},
                            {"max_samples", options.maxSamples},
                            {"rate", rate},
                            {"fixed_ms", options.rateSamplesPerMs > 0 ? options.fixedMs : 0.0}};
  try {
    broadcastText(mComm, command.dump(), timeout);
    agreeOnDataset(mComm, dataset->name(), ownRecord(dataset->name()), timeout);
    nlohmann::json distributed;
    image::ImageF image = renderer.render(dataset, scene, stats, &distributed, frameOptionsOf(command));
    spdlog::debug("distributed frame: {}", distributed.dump());
    return image;
  } catch (const PeerError& error) {
    mLost = error.what();
    spdlog::error("distributed mode: {}", error.what());
    throw render::RenderError(std::string("distributed frame failed: ") + error.what());
  }
}

SortLastSource::SortLastSource(std::shared_ptr<FrameLeader> leader, MPI_Comm comm, const ServeRankOptions& options)
    : mLeader(std::move(leader)), mEngine(options.engine), mRenderer(comm, mEngine, options.frames) {
  MPI_Comm_size(comm, &mRanks);
}

std::string SortLastSource::describe() const {
  return mEngine.describe() + ", sort-last across " + std::to_string(mRanks) + " MPI ranks";
}

image::ImageF SortLastSource::render(const std::shared_ptr<const render::Dataset>& dataset,
                                     const render::Scene& scene, render::FrameStats* stats,
                                     const render::FrameOptions& options) {
  if (!dataset || options.part || !render::driverFor(*dataset).sortsLast())
    return mEngine.render(dataset, scene, stats, options);
  return mLeader->frame(mRenderer, mEngine.recentRate(*dataset), dataset, scene, stats, options);
}

void SortLastSource::prefetch(const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene) {
  try {
    if (dataset && !render::driverFor(*dataset).sortsLast()) mEngine.prefetch(dataset, scene);
  } catch (...) {
    // Advisory.
  }
}

std::string FrameLeader::ownRecord(const std::string& name) const {
  try {
    return "ok " + datasetIdentity(mOptions.datasets / name);
  } catch (const std::exception& error) {
    return std::string("error ") + error.what();
  }
}

void FrameLeader::checkDataset(const std::string& name) {
  std::lock_guard lock(mMutex);
  if (mLost) throw render::RenderError("the distributed mode stopped earlier: " + *mLost + "; restart the server");
  const double timeout = mOptions.frames.composite.timeoutSeconds;
  try {
    broadcastText(mComm, nlohmann::json{{"op", "open"}, {"name", name}}.dump(), timeout);
    agreeOnDataset(mComm, name, ownRecord(name), timeout);
  } catch (const PeerError& error) {
    mLost = error.what();
    spdlog::error("distributed mode: {}", error.what());
    throw render::RenderError(std::string("distributed open failed: ") + error.what());
  }
}

bool FrameLeader::quit() {
  std::lock_guard lock(mMutex);
  try {
    // A lost rank would never reach MPI_Finalize: then no rank calls it.
    broadcastText(mComm, nlohmann::json{{"op", "quit"}, {"in_step", !mLost}}.dump(), 1.0);
    return !mLost;
  } catch (const PeerError& error) {
    spdlog::warn("distributed mode: quitting: {}", error.what());
    return false;
  }
}

bool runWorker(MPI_Comm comm, const ServeRankOptions& options, const std::atomic<bool>& stopRequested,
               double graceSeconds) {
  render::RenderEngine engine(options.engine);
  RankRenderer renderer(comm, engine, options.frames);
  WorkerDatasets datasets(options.datasets, options.hostCacheBytes);
  std::optional<std::chrono::steady_clock::time_point> stopSeen;
  auto giveUp = [&] {
    if (!stopRequested) return false;
    if (!stopSeen) stopSeen = std::chrono::steady_clock::now();
    return std::chrono::steady_clock::now() - *stopSeen > std::chrono::duration<double>(graceSeconds);
  };
  const double timeout = options.frames.composite.timeoutSeconds;
  while (true) {
    const std::string text = broadcastText(comm, {}, -1, giveUp);
    if (text.empty()) return false;  // stopped without rank 0's word
    const nlohmann::json command = nlohmann::json::parse(text, nullptr, false);
    if (command.is_discarded()) return false;
    if (command.value("op", "") == "quit") return command.value("in_step", false);
    const std::string name = command.value("name", "");
    const bool framing = command.value("op", "") == "frame";
    std::shared_ptr<const render::Dataset> dataset;
    std::optional<render::Scene> scene;
    std::string record;
    try {  // a scene this rank cannot read fails the agreement on every rank, so no rank is left out of step
      if (framing) scene = render::Scene::fromJson(command.value("scene", ""), "the frame's scene");
      std::string identity;
      dataset = datasets.open(name, identity);
      record = "ok " + identity;
    } catch (const std::exception& error) {
      record = std::string("error ") + error.what();
    }
    try {
      agreeOnDataset(comm, name, record, timeout);
      if (framing) renderer.render(dataset, *scene, nullptr, nullptr, frameOptionsOf(command));
    } catch (const PeerError& error) {
      spdlog::error("distributed mode: {}", error.what());
      return false;  // out of step with rank 0: leave
    } catch (const std::exception& error) {
      spdlog::debug("distributed frame refused: {}", error.what());
    }
  }
}

}  // namespace voxbrick::distributed
