// The PACS catalog: listings on a thread of their own, preps one at a time on another, the cache and its eviction.
#include "server/PacsCatalog.h"

#include <sys/stat.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <set>
#include <stdexcept>

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "brickstore/ingest/dicomweb/HttpClient.h"
#include "brickstore/ingest/dicomweb/SeriesSearch.h"
#include "proto/Messages.h"

namespace voxbrick::server {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr uint32_t kRetryMs = 1000;
constexpr const char* kScratchPrefix = ".tmp-";

/// The sidecar beside a cached store: what it was prepped from (its instance count tells a changed series).
fs::path sidecar(const fs::path& dir, const std::string& name) { return dir / (name + ".json"); }

/// The instance count a sidecar records; -2 when it cannot be read.
int64_t recordedInstances(const fs::path& record) {
  std::ifstream in(record);
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  return j.is_object() && j.contains("instances") && j["instances"].is_number_integer() ? j["instances"].get<int64_t>()
                                                                                        : -2;
}

/// How often the record of a store opened again is touched (its time is the last open, for a restarted server).
constexpr auto kTouchEvery = std::chrono::seconds(60);

uint64_t bytesUnder(const fs::path& dir) {
  uint64_t total = 0;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec))
    if (it->is_regular_file(ec)) total += it->file_size(ec);
  return total;
}

std::string isoTime(std::chrono::system_clock::time_point t) {
  return fmt::format("{:%Y-%m-%dT%H:%M:%SZ}", fmt::gmtime(std::chrono::system_clock::to_time_t(t)));
}

/// The dicomweb[s]:// input `voxbrick prep` takes for series `series` of the PACS whose DICOMweb root is `url`.
std::string prepInput(const PacsConfig& pacs, const store::QidoSeries& series) {
  if (series.studyUid.empty())
    throw std::runtime_error("PACS '" + pacs.id + "' listed series " + series.seriesUid +
                             " without its StudyInstanceUID: it cannot be fetched");
  const bool https = pacs.url.starts_with("https://");
  std::string root = pacs.url.substr(pacs.url.find("//") + 2);
  while (!root.empty() && root.back() == '/') root.pop_back();
  return std::string(https ? "dicomwebs://" : "dicomweb://") + root + "/studies/" + series.studyUid + "/series/" +
         series.seriesUid;
}

std::vector<store::QidoSeries> listByQido(const PacsConfig& pacs, const std::function<bool()>& stopping) {
  store::HttpOptions options;
  options.cancelled = stopping;
  options.caFile = pacs.ca.string();
  options.credentials = store::readHttpCredentials(pacs.authFile.string());
  options.retries = 1;
  return store::searchImageSeries(pacs.url, options);
}

}  // namespace

PacsCatalog::PacsCatalog(std::vector<PacsConfig> pacs, PacsCacheConfig cache, fs::path voxbrick, Lister lister,
                         Prepper prepper, std::chrono::milliseconds abandonedAfter)
    : mCache(std::move(cache)),
      mVoxbrick(std::move(voxbrick)),
      mAbandonedAfter(abandonedAfter),
      mLister(std::move(lister)),
      mPrepper(std::move(prepper)) {
  if (!mLister) mLister = listByQido;
  if (!mPrepper)
    mPrepper = [exe = mVoxbrick](const PacsConfig& p, const store::QidoSeries& s, const fs::path& out,
                                 const fs::path& log, PrepProcess& process) {
      std::vector<std::string> args = {"prep", prepInput(p, s), "-o", out.string(), "-q"};
      if (!p.authFile.empty()) args.insert(args.end(), {"--auth-file", p.authFile.string()});
      if (!p.ca.empty()) args.insert(args.end(), {"--ca", p.ca.string()});
      process.run(exe, args, log, "series " + s.seriesUid + " of PACS '" + p.id + "'");
    };
  for (PacsConfig& p : pacs) mPacs.push_back(Pacs{std::move(p), {}, {}, "not listed yet", {}});
  fs::create_directories(mCache.dir);
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(mCache.dir, ec)) {
    const std::string file = entry.path().filename().string();
    if (file.starts_with(kScratchPrefix)) {
      fs::remove_all(entry.path(), ec);  // a prep the server did not finish
    } else if (entry.is_directory() && fs::exists(sidecar(mCache.dir, file))) {
      // The last open of each store outlives the server in its sidecar's modification time.
      const auto written = fs::last_write_time(sidecar(mCache.dir, file), ec);
      mOpened[file] = std::chrono::file_clock::to_sys(written);
      mCached[file] = recordedInstances(sidecar(mCache.dir, file));
    }
  }
}

PacsCatalog::~PacsCatalog() { stop(); }

void PacsCatalog::start() {
  std::lock_guard lock(mMutex);
  if (mStarted || mStopping) return;
  mStarted = true;
  mListing = std::thread([this] { listingLoop(); });
  mPreparing = std::thread([this] { prepLoop(); });
}

void PacsCatalog::stop() {
  {
    std::lock_guard lock(mMutex);
    mStopping = true;
    if (mRunning) mRunning->cancel();
  }
  mWake.notify_all();
  if (mListing.joinable()) mListing.join();
  if (mPreparing.joinable()) mPreparing.join();
}

void PacsCatalog::listingLoop() {
  std::unique_lock lock(mMutex);
  while (!mStopping) {
    const auto now = Clock::now();
    auto next = now + std::chrono::hours(24);
    bool due = false;
    for (const Pacs& p : mPacs) {
      due = due || p.nextListing <= now;
      next = std::min(next, p.nextListing);
    }
    if (!due) {
      mWake.wait_until(lock, next);
      continue;
    }
    lock.unlock();
    list(false);
    lock.lock();
  }
}

void PacsCatalog::refresh() { list(true); }

void PacsCatalog::list(bool all) {
  for (size_t i = 0;; ++i) {
    PacsConfig config;
    {
      std::lock_guard lock(mMutex);
      if (i >= mPacs.size() || mStopping) return;
      if (!all && mPacs[i].nextListing > Clock::now()) continue;
      config = mPacs[i].config;
    }
    std::vector<store::QidoSeries> listed;
    std::string error;
    try {
      listed = mLister(config, [this] { return mStopping.load(); });
    } catch (const std::exception& e) {
      error = e.what();
    }
    std::lock_guard lock(mMutex);
    Pacs& p = mPacs[i];
    p.nextListing = Clock::now() + std::chrono::milliseconds(int64_t(config.refreshS * 1000));
    if (!error.empty()) {
      if (p.error != error) spdlog::warn("PACS '{}': listing its series failed: {}", config.id, error);
      p.error = error;
      continue;
    }
    std::map<std::string, Listed> series;
    for (store::QidoSeries& s : listed) {
      const std::string name = config.id + "." + s.seriesUid;
      series[name] = Listed{config.id, std::move(s)};
    }
    if (!p.error.empty() || p.series.size() != series.size())
      spdlog::info("PACS '{}': {} image series listed", config.id, series.size());
    p.series = std::move(series);
    p.error.clear();
    p.listedAt = std::chrono::system_clock::now();
  }
}

const PacsCatalog::Pacs* PacsCatalog::pacsOf(const std::string& name) const {
  const size_t dot = name.find('.');
  if (dot == std::string::npos) return nullptr;
  for (const Pacs& p : mPacs)
    if (name.compare(0, dot, p.config.id) == 0 && p.config.id.size() == dot) return &p;
  return nullptr;
}

bool PacsCatalog::owns(const std::string& name) const {
  std::lock_guard lock(mMutex);
  return pacsOf(name) != nullptr;
}

std::vector<std::string> PacsCatalog::names() const {
  std::lock_guard lock(mMutex);
  std::set<std::string> out;
  for (const Pacs& p : mPacs)
    for (const auto& [name, listed] : p.series) out.insert(name);
  // A PACS that cannot be listed now: what its cache holds can still be opened.
  for (const auto& cached : mCached) {
    const Pacs* p = pacsOf(cached.first);
    if (p && !p->error.empty()) out.insert(cached.first);
  }
  return {out.begin(), out.end()};
}

int64_t PacsCatalog::cachedInstances(const std::string& name) const {
  const auto it = mCached.find(name);
  return it == mCached.end() ? -1 : it->second;
}

fs::path PacsCatalog::resolve(const std::string& name) {
  std::lock_guard lock(mMutex);
  const Pacs* p = pacsOf(name);
  if (!p) throw std::out_of_range("no PACS is named by '" + name + "'");
  if (const auto failed = mFailed.find(name); failed != mFailed.end()) {
    const std::string why = failed->second;
    mFailed.erase(failed);
    throw std::runtime_error(why);
  }
  const auto listed = p->series.find(name);
  for (Job& j : mQueue)
    if (j.name == name) j.askedAt = Clock::now();
  // One stat a request (the registry stats the store's files anyway): a store deleted by hand is fetched again.
  if (mCached.count(name) && !fs::exists(mCache.dir / name / "store.json")) {
    mCached.erase(name);
    mOpened.erase(name);
  }
  const int64_t cached = cachedInstances(name);
  const bool queued = std::any_of(mQueue.begin(), mQueue.end(), [&](const Job& j) { return j.name == name; });
  const bool changed = cached >= 0 && listed != p->series.end() && listed->second.series.instances >= 0 &&
                       listed->second.series.instances != cached;
  if (cached != -1) {
    // A series changed on the PACS is fetched again in the background; its cached store serves until the new one
    // replaces it.
    if (changed && !queued) {
      spdlog::info("PACS '{}': {} changed ({} instances, {} cached): fetching it again", p->config.id, name,
                   listed->second.series.instances, cached);
      mQueue.push_back(Job{name, Clock::now()});
      mWake.notify_all();
    }
    // Every Render of the series comes here: the record's time is touched once a minute, not per frame.
    const auto now = std::chrono::system_clock::now();
    auto& opened = mOpened[name];
    if (now - opened > kTouchEvery) {
      std::error_code ec;
      fs::last_write_time(sidecar(mCache.dir, name), fs::file_time_type::clock::now(), ec);
    }
    opened = now;
    return mCache.dir / name;
  }
  if (listed == p->series.end())
    throw std::out_of_range("no series " + name.substr(name.find('.') + 1) + " in PACS '" + p->config.id + "'" +
                            (p->error.empty() ? "" : " (its listing failed: " + p->error + ")"));
  if (!queued) {
    mQueue.push_back(Job{name, Clock::now()});
    mWake.notify_all();
  }
  const auto job = std::find_if(mQueue.begin(), mQueue.end(), [&](const Job& j) { return j.name == name; });
  const auto& s = listed->second.series;
  std::string what = "series " + s.seriesUid + " of PACS '" + p->config.id + "'" +
                     (s.instances >= 0
                          ? " (" + std::to_string(s.instances) + (s.instances == 1 ? " instance)" : " instances)")
                          : "");
  const size_t ahead = size_t(job - mQueue.begin());
  what = job->running ? "fetching " + what + ": " +
                            std::to_string(int(std::chrono::duration<double>(Clock::now() - job->startedAt).count())) +
                            " s so far"
                      : what + (ahead == 0 ? " is about to be fetched"
                                           : " waits for " + std::to_string(ahead) + " series fetched before it");
  throw proto::ProtocolError(proto::ErrorCode::Busy, proto::busyMessage(what, kRetryMs));
}

void PacsCatalog::prepLoop() {
  std::unique_lock lock(mMutex);
  while (true) {
    mWake.wait(lock, [&] { return mStopping || (!mQueue.empty() && !mQueue.front().running); });
    if (mStopping) return;
    const auto now = Clock::now();
    std::erase_if(mQueue, [&](const Job& j) {
      if (now - j.askedAt <= mAbandonedAfter) return false;
      spdlog::info("PACS: {} no longer asked for: not fetched", j.name);
      return true;
    });
    if (mQueue.empty()) continue;
    Job& job = mQueue.front();
    job.running = true;
    job.startedAt = Clock::now();
    const std::string name = job.name;
    lock.unlock();
    prepare(name);
    lock.lock();
    mQueue.pop_front();
    mRunning.reset();
    const std::vector<fs::path> evicted = evict(name);
    // Deleting a store can take a while: not while sessions wait for the lock to list or open datasets.
    lock.unlock();
    std::error_code ec;
    for (const fs::path& path : evicted) fs::remove_all(path, ec);
    lock.lock();
  }
}

void PacsCatalog::prepare(const std::string& name) {
  PacsConfig config;
  store::QidoSeries series;
  auto process = std::make_shared<PrepProcess>();
  {
    std::lock_guard lock(mMutex);
    const Pacs* p = pacsOf(name);
    const auto listed = p ? p->series.find(name) : decltype(p->series.end()){};
    if (!p || listed == p->series.end()) return;
    config = p->config;
    series = listed->second.series;
    if (mStopping) return;  // stop() cancels mRunning: set it only while it can still be cancelled
    mRunning = process;
  }
  std::string pattern = (mCache.dir / (std::string(kScratchPrefix) + "XXXXXX")).string();
  std::string error;
  if (!::mkdtemp(pattern.data())) {
    error = "cannot make a scratch folder in the PACS cache";
  } else {
    const fs::path scratch = pattern;
    const auto started = Clock::now();
    try {
      mPrepper(config, series, scratch / "store", scratch / "prep.log", *process);
      // The new store replaces a changed one in two renames: sessions holding the old one open the new at their
      // next frame (DatasetRegistry sees other files).
      // The sidecar goes first: a store in the cache always has one (resolve() reads its instance count).
      const nlohmann::json meta = {{"pacs", config.id},
                                   {"study", series.studyUid},
                                   {"series", series.seriesUid},
                                   {"instances", series.instances},
                                   {"prepped", isoTime(std::chrono::system_clock::now())}};
      std::ofstream(scratch / "meta.json") << meta.dump(2) << "\n";
      fs::rename(scratch / "meta.json", sidecar(mCache.dir, name));
      const fs::path target = mCache.dir / name, old = scratch / "old";
      if (fs::exists(target)) fs::rename(target, old);
      fs::rename(scratch / "store", target);
      spdlog::info("PACS '{}': series {} prepped into the cache in {:.1f} s", config.id, series.seriesUid,
                   std::chrono::duration<double>(Clock::now() - started).count());
    } catch (const std::exception& e) {
      error = e.what();
    }
    std::error_code ec;
    fs::remove_all(scratch, ec);
  }
  std::lock_guard lock(mMutex);
  if (!error.empty() && !mStopping) {
    spdlog::warn("PACS '{}': {}", config.id, error);
    mFailed[name] = error;
  }
  if (error.empty()) {
    mOpened[name] = std::chrono::system_clock::now();
    mCached[name] = series.instances;
  }
}

std::vector<fs::path> PacsCatalog::evict(const std::string& keep) {
  struct Entry {
    std::string name;
    uint64_t bytes;
    std::chrono::system_clock::time_point opened;
  };
  std::vector<Entry> entries;
  uint64_t total = 0;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(mCache.dir, ec)) {
    const std::string name = e.path().filename().string();
    if (!e.is_directory() || name.starts_with(".")) continue;
    const uint64_t bytes = bytesUnder(e.path());
    total += bytes;
    const auto opened = mOpened.find(name);
    entries.push_back({name, bytes, opened == mOpened.end() ? std::chrono::system_clock::time_point{} : opened->second});
  }
  const uint64_t limit = uint64_t(mCache.maxMB) << 20;
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.opened < b.opened; });
  std::vector<fs::path> evicted;
  for (const Entry& e : entries) {
    if (total <= limit) break;
    const bool waiting = std::any_of(mQueue.begin(), mQueue.end(), [&](const Job& j) { return j.name == e.name; });
    if (e.name == keep || waiting) continue;
    std::string pattern = (mCache.dir / (std::string(kScratchPrefix) + "XXXXXX")).string();
    if (!::mkdtemp(pattern.data())) break;
    // Out of the cache in two renames, the record first: a store never stays without its record.
    fs::rename(sidecar(mCache.dir, e.name), fs::path(pattern) / "record.json", ec);
    fs::rename(mCache.dir / e.name, fs::path(pattern) / "store", ec);
    spdlog::info("PACS cache: evicting {} ({} MB, least recently opened) to stay within {} MB", e.name,
                 e.bytes >> 20, mCache.maxMB);
    evicted.push_back(pattern);
    mOpened.erase(e.name);
    mCached.erase(e.name);
    total -= e.bytes;
  }
  return evicted;
}

nlohmann::json PacsCatalog::toJson(const std::function<bool(const std::string&)>& visible) const {
  std::lock_guard lock(mMutex);
  nlohmann::json out = nlohmann::json::array();
  for (const Pacs& p : mPacs) {
    nlohmann::json series = nlohmann::json::array();
    for (const auto& [name, listed] : p.series) {
      if (visible && !visible(name)) continue;
      const store::QidoSeries& s = listed.series;
      const bool queued = std::any_of(mQueue.begin(), mQueue.end(), [&](const Job& j) { return j.name == name; });
      const bool running = !mQueue.empty() && mQueue.front().name == name && mQueue.front().running;
      nlohmann::json entry = {{"name", name},
                              {"modality", s.modality},
                              {"description", s.description},
                              {"instances", s.instances},
                              {"study", s.studyUid},
                              {"study_description", s.studyDescription},
                              {"study_date", s.studyDate},
                              {"state", running           ? "fetching"
                                        : queued          ? "queued"
                                        : mFailed.count(name) ? "failed"
                                        : cachedInstances(name) != -1 ? "cached"
                                                                      : "remote"}};
      if (p.config.patientFields)
        entry["patient"] = {{"name", s.patientName}, {"id", s.patientId}, {"birth_date", s.patientBirthDate}};
      series.push_back(std::move(entry));
    }
    out.push_back({{"id", p.config.id},
                   {"url", p.config.url},
                   {"listed_at", p.listedAt == std::chrono::system_clock::time_point{} ? nlohmann::json(nullptr)
                                                                                      : nlohmann::json(isoTime(p.listedAt))},
                   {"error", p.error.empty() ? nlohmann::json(nullptr) : nlohmann::json(p.error)},
                   {"series", std::move(series)}});
  }
  return out;
}

}  // namespace voxbrick::server
