// Rank 0's frame leader and frame source, and the workers' loop of `serve --mpi` (ServeRanks.h).
#include "distributed/ServeRanks.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <map>
#include <thread>

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
  options.outputScale = command.value("output_scale", 1.0);
  return options;
}

/// How long rank 0 waits for the answers to a regroup: a worker that was waiting on a lost peer comes back within
/// its deadline.
double regroupSeconds(double timeoutSeconds) { return timeoutSeconds + 2; }

}  // namespace

/// A rank left out of the last regroup whose answer may still come: its receive and buffer.
struct FrameLeader::LateAnswer {
  int rank = -1;
  MPI_Request request = MPI_REQUEST_NULL;
  std::shared_ptr<std::array<char, 8>> buffer;
};

FrameLeader::FrameLeader(MPI_Comm comm, ServeRankOptions options)
    : mComm(comm), mOptions(std::move(options)), mGroup(RankGroup::all(comm)), mLost(nlohmann::json::array()) {
  MPI_Comm_size(comm, &mWorldSize);
}

FrameLeader::~FrameLeader() {
  for (auto& late : mLate) abandonRequest(late.request, std::move(late.buffer));
}

render::RenderError FrameLeader::lose(const PeerError& error, const char* what) {
  mFailure = error.what();
  mSuspect = error.rank();
  mEverLost = true;
  spdlog::error("distributed mode: {}", error.what());
  return render::RenderError(std::string("distributed ") + what + " failed: " + error.what());
}

void FrameLeader::regroup(const std::vector<int>& candidates) {
  const int epoch = mGroup.epoch + 1;
  if (epoch > RankGroup::lastEpoch(mComm)) {
    mStopped = "the ranks regrouped " + std::to_string(mGroup.epoch) + " times, as many as MPI's tags allow";
    return;
  }
  RankGroup next{mComm, {0}, epoch};
  const std::string probe = nlohmann::json{{"op", "regroup"}, {"epoch", epoch}}.dump();
  auto text = std::make_shared<std::string>(probe);
  Transfers probes(mComm, 0);  // not waited for: a rank that takes its probe answers it
  for (auto& late : mLate) abandonRequest(late.request, std::move(late.buffer));  // an earlier epoch's
  mLate.clear();
  std::vector<LateAnswer> awaited;
  for (int r : candidates) {
    LateAnswer answer{r, MPI_REQUEST_NULL, std::make_shared<std::array<char, 8>>()};
    if (MPI_Irecv(answer.buffer->data(), 8, MPI_BYTE, r, next.tag(kAnswerTag), mComm, &answer.request) != MPI_SUCCESS)
      continue;
    awaited.push_back(std::move(answer));
    try {
      probes.send(r, next.tag(kCommandTag), text->data(), text->size(), text, "a regroup");
    } catch (const PeerError& error) {
      spdlog::warn("distributed mode: regrouping: {}", error.what());
    }
  }
  // The answers, until every candidate's is in or the deadline passed; a rank that has not answered by then is left
  // out, and its answer still listened for (mLate): it is taken back if it comes. The rank the failed frame named is
  // not waited for once the others have answered (after a short grace): a dead or stopped rank would otherwise hold
  // the first frame after its loss for the whole deadline, and a live one named by mistake is taken back at the
  // next frame.
  const auto start = std::chrono::steady_clock::now();
  const auto deadline = start + std::chrono::duration<double>(regroupSeconds(mOptions.frames.composite.timeoutSeconds));
  const auto grace = start + std::chrono::milliseconds(250);
  while (true) {
    bool waiting = false, waitingForOthers = false;
    for (auto& answer : awaited) {
      if (answer.request == MPI_REQUEST_NULL) continue;
      int done = 0;
      if (MPI_Test(&answer.request, &done, MPI_STATUS_IGNORE) != MPI_SUCCESS) {
        abandonRequest(answer.request, std::move(answer.buffer));  // a dead rank: never taken back
        answer.request = MPI_REQUEST_NULL;
        answer.rank = -1;
      } else if (done) {
        next.members.push_back(answer.rank);
      } else {
        waiting = true;
        waitingForOthers = waitingForOthers || answer.rank != mSuspect;
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (!waiting || now > deadline || (!waitingForOthers && mFailure && now > grace)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  for (auto& answer : awaited)
    if (answer.request != MPI_REQUEST_NULL) mLate.push_back(std::move(answer));
  nlohmann::json lost = nlohmann::json::array();
  for (int r = 1; r < mWorldSize; ++r) {
    if (next.indexOf(r) >= 0) continue;
    std::string reason = "did not answer a regroup within " +
                         std::to_string(int(regroupSeconds(mOptions.frames.composite.timeoutSeconds))) + " s";
    for (const auto& earlier : mLost)
      if (earlier.value("rank", -1) == r) reason = earlier.value("reason", reason);
    if (r == mSuspect && mFailure) reason = *mFailure;
    lost.push_back({{"rank", r}, {"reason", reason}});
  }
  std::sort(next.members.begin(), next.members.end());
  mGroup = next;
  mLost = lost;
  mFailure.reset();
  mSuspect = -1;
  spdlog::warn("distributed mode: ranks regrouped (epoch {}): members {}, lost {}", mGroup.epoch,
               nlohmann::json(mGroup.members).dump(), mLost.dump());
}

void FrameLeader::regroupIfNeeded() {
  bool lateAnswer = false;
  for (auto& late : mLate) {
    int done = 0;
    if (late.request != MPI_REQUEST_NULL && MPI_Test(&late.request, &done, MPI_STATUS_IGNORE) == MPI_SUCCESS && done) {
      late.request = MPI_REQUEST_NULL;
      lateAnswer = true;
    }
  }
  if (mFailure) {
    std::vector<int> everyOther;  // the lost ranks too: one that answers after all is taken back
    for (int r = 1; r < mWorldSize; ++r) everyOther.push_back(r);
    regroup(everyOther);
  } else if (lateAnswer) {
    std::vector<int> candidates(mGroup.members.begin() + 1, mGroup.members.end());
    for (const auto& late : mLate)
      if (late.request == MPI_REQUEST_NULL) candidates.push_back(late.rank);
    std::sort(candidates.begin(), candidates.end());
    regroup(candidates);
  }
}

image::ImageF FrameLeader::frame(RankRenderer& renderer, double recentRate,
                                 const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene,
                                 render::FrameStats* stats, const render::FrameOptions& options,
                                 image::Image8* frame8) {
  std::lock_guard lock(mMutex);
  regroupIfNeeded();
  if (mStopped)
    throw render::RenderError("the distributed mode stopped earlier: " + *mStopped + "; restart the server");
  const double timeout = mOptions.frames.composite.timeoutSeconds;
  // Every rank draws the same interactive rung: chosen by rank 0's rate (none known yet: the cheapest), sent in the
  // frame's command with its deadline.
  const double rate = rateOrCheapest(options.rateSamplesPerMs > 0 ? options.rateSamplesPerMs : recentRate);
  nlohmann::json command = {{"op", "frame"},
                            {"name", dataset->name()},
                            {"members", mGroup.members},
                            {"scene", scene.toJson()},
                            {"stand_ins", options.standIns},
                            {"max_samples", options.maxSamples},
                            {"rate", rate},
                            {"fixed_ms", options.rateSamplesPerMs > 0 ? options.fixedMs : 0.0},
                            {"output_scale", options.outputScale}};
  try {
    sendCommand(mGroup, command.dump(), timeout);
    agreeOnDataset(mGroup, dataset->name(), ownRecord(dataset->name()), timeout);
    image::ImageF image = renderer.render(mGroup, dataset, scene, stats, frameOptionsOf(command), mLost, frame8);
    if (stats) spdlog::debug("distributed frame: {}", stats->distributed.dump());
    return image;
  } catch (const PeerError& error) {
    throw lose(error, "frame");
  }
}

SortLastSource::SortLastSource(std::shared_ptr<FrameLeader> leader, MPI_Comm comm, const ServeRankOptions& options)
    : mLeader(std::move(leader)), mEngine(options.engine), mRenderer(comm, mEngine, options.frames) {
  MPI_Comm_size(comm, &mRanks);
}

std::string SortLastSource::describe() const {
  return mEngine.describe() + ", sort-last across " + std::to_string(mRanks) + " MPI ranks";
}

image::ImageF SortLastSource::distributed(const std::shared_ptr<const render::Dataset>& dataset,
                                          const render::Scene& scene, render::FrameStats* stats,
                                          const render::FrameOptions& options, image::Image8* frame8) {
  render::RateGauge& rate = mRates[std::string(dataset->kind())];
  render::FrameStats own;
  image::ImageF image = mLeader->frame(mRenderer, rate.rate(), dataset, scene, &own, options, frame8);
  rate.add(own.samplesEstimated, own.msTotal);
  if (stats) *stats = std::move(own);
  return image;
}

image::ImageF SortLastSource::render(const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene,
                                     render::FrameStats* stats, const render::FrameOptions& options) {
  if (!dataset || options.part || options.meshPart || !render::driverFor(*dataset).sortsLast())
    return mEngine.render(dataset, scene, stats, options);
  return distributed(dataset, scene, stats, options, nullptr);
}

image::Image8 SortLastSource::render8(const std::shared_ptr<const render::Dataset>& dataset, const render::Scene& scene,
                                      render::FrameStats* stats, const render::FrameOptions& options) {
  if (!dataset || options.part || options.meshPart || !render::driverFor(*dataset).sortsLast())
    return mEngine.render8(dataset, scene, stats, options);
  image::Image8 frame8;
  image::ImageF image = distributed(dataset, scene, stats, options, &frame8);
  return frame8.rgba.empty() ? image::toImage8(image) : std::move(frame8);
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
  regroupIfNeeded();
  if (mStopped)
    throw render::RenderError("the distributed mode stopped earlier: " + *mStopped + "; restart the server");
  const double timeout = mOptions.frames.composite.timeoutSeconds;
  try {
    sendCommand(mGroup, nlohmann::json{{"op", "open"}, {"name", name}, {"members", mGroup.members}}.dump(), timeout);
    agreeOnDataset(mGroup, name, ownRecord(name), timeout);
  } catch (const PeerError& error) {
    throw lose(error, "open");
  }
}

bool FrameLeader::quit() {
  std::lock_guard lock(mMutex);
  // Every other rank, members or not (one left out may be waiting still). A lost rank would never reach
  // MPI_Finalize: then no rank calls it.
  const bool inStep = !mEverLost;
  RankGroup everyone = RankGroup::all(mComm);
  everyone.epoch = mGroup.epoch;
  auto text = std::make_shared<std::string>(nlohmann::json{{"op", "quit"}, {"in_step", inStep}}.dump());
  Transfers transfers(mComm, 1.0);
  for (int r = 1; r < mWorldSize; ++r) {
    try {
      transfers.send(r, everyone.tag(kCommandTag), text->data(), text->size(), text, "quit");
    } catch (const PeerError& error) {
      spdlog::warn("distributed mode: quitting: {}", error.what());
    }
  }
  const std::vector<bool> told = transfers.waitEach();
  const bool all = std::count(told.begin(), told.end(), true) == mWorldSize - 1;
  if (!all) spdlog::warn("distributed mode: quitting: some ranks did not take the word to leave within a second");
  return inStep && all;
}

bool runWorker(MPI_Comm comm, const ServeRankOptions& options, const std::atomic<bool>& stopRequested,
               double graceSeconds) {
  render::RenderEngine engine(options.engine);
  RankRenderer renderer(comm, engine, options.frames);
  WorkerDatasets datasets(options.datasets, options.hostCacheBytes);
  int self = 0;
  MPI_Comm_rank(comm, &self);
  std::optional<std::chrono::steady_clock::time_point> stopSeen;
  auto giveUp = [&] {
    if (!stopRequested) return false;
    if (!stopSeen) stopSeen = std::chrono::steady_clock::now();
    return std::chrono::steady_clock::now() - *stopSeen > std::chrono::duration<double>(graceSeconds);
  };
  const double timeout = options.frames.composite.timeoutSeconds;
  int epoch = 0;
  bool inStep = true;
  while (true) {
    const std::optional<Command> taken = receiveCommand(comm, epoch, -1, giveUp);
    if (!taken) return false;  // stopped without rank 0's word
    epoch = taken->epoch;      // a later epoch: rank 0 regrouped the ranks
    const nlohmann::json command = nlohmann::json::parse(taken->text, nullptr, false);
    if (command.is_discarded() || !command.is_object()) continue;
    const std::string op = command.value("op", "");
    if (op == "quit") return inStep && command.value("in_step", false);
    if (op == "regroup") {  // answered: this rank draws again from the next frame
      const RankGroup group{comm, {}, epoch};
      auto answer = std::make_shared<std::array<char, 8>>();
      Transfers transfers(comm, timeout);
      try {
        transfers.send(0, group.tag(kAnswerTag), answer->data(), answer->size(), answer, "an answer to a regroup");
        transfers.wait();
      } catch (const PeerError& error) {
        spdlog::error("distributed mode: {}", error.what());
      }
      continue;
    }
    RankGroup group{comm, command.value("members", std::vector<int>{}), epoch};
    if (group.indexOf(self) < 0 || group.indexOf(0) != 0) continue;  // not drawing in this epoch
    const std::string name = command.value("name", "");
    const bool framing = op == "frame";
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
      agreeOnDataset(group, name, record, timeout);
      if (framing) renderer.render(group, dataset, *scene, nullptr, frameOptionsOf(command));
    } catch (const PeerError& error) {
      // Out of step with rank 0 for this frame: rank 0 regroups the ranks before the next one.
      spdlog::error("distributed mode: {}", error.what());
      inStep = false;
    } catch (const std::exception& error) {
      spdlog::debug("distributed frame refused: {}", error.what());
    }
  }
}

}  // namespace voxbrick::distributed
