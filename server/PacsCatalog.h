// A PACS as datasets (docs/server.md, "A PACS as datasets"): the image series of each [[pacs]] entry, listed by
// QIDO-RS every refresh_s, are datasets named "ID.SERIESUID"; the first OpenDataset of one preps it from DICOMweb in
// the background (`voxbrick prep dicomweb://...`, a child process) and is answered Busy with its progress until its
// store is in the PACS cache, which keeps stores up to a size, the least recently opened evicted first. A series
// whose instance count changed on the PACS is prepped again when next opened (the cached one serving meanwhile). No
// sockets here.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "brickstore/ingest/dicomweb/QidoResults.h"
#include "server/PrepProcess.h"
#include "server/ServerConfig.h"

namespace voxbrick::server {

class PacsCatalog {
 public:
  /// Lists the image series of a PACS (QIDO-RS: store::searchImageSeries); throws with the failure (the URL and the
  /// HTTP status). `stopping` says when to give up (the server stops).
  using Lister =
      std::function<std::vector<store::QidoSeries>(const PacsConfig&, const std::function<bool()>& stopping)>;
  /// Preps series `series` of `pacs` into the store `out`, its output in `log`, through `process` (which the catalog
  /// cancels when it stops); throws with prep's words.
  using Prepper = std::function<void(const PacsConfig& pacs, const store::QidoSeries& series,
                                     const std::filesystem::path& out, const std::filesystem::path& log,
                                     PrepProcess& process)>;

  /// The PACS of `pacs`, their stores kept in `cache.dir` (created; must not be empty) within cache.maxMB. `lister`
  /// and `prepper` default to QIDO-RS over libcurl and `voxbrick prep dicomweb://...` run as `voxbrick`.
  /// `abandonedAfter`: a queued series not asked for again within it is dropped before its prep starts.
  PacsCatalog(std::vector<PacsConfig> pacs, PacsCacheConfig cache, std::filesystem::path voxbrick,
              Lister lister = {}, Prepper prepper = {},
              std::chrono::milliseconds abandonedAfter = std::chrono::seconds(10));
  /// Stops (stop()).
  ~PacsCatalog();
  PacsCatalog(const PacsCatalog&) = delete;
  PacsCatalog& operator=(const PacsCatalog&) = delete;

  /// Starts listing each PACS now and every refresh_s, and preparing series as they are asked for.
  void start();
  /// Stops listing and preparing (a prep running is killed, its scratch removed). Idempotent.
  void stop();
  /// Lists every PACS once, now, on the calling thread (what the listing thread does each time).
  void refresh();

  /// Whether `name` names a series of a configured PACS ("ID.SERIESUID" of a configured id), listed or not.
  bool owns(const std::string& name) const;
  /// The series datasets: those listed at the last listing of their PACS, and those in the cache of a PACS whose
  /// listing failed (what can still be opened). Sorted.
  std::vector<std::string> names() const;
  /// The store of series `name`, ready to open: its path in the cache. A series not in the cache is queued for prep,
  /// and the call throws proto::ProtocolError Busy saying where it stands ("fetching series ... of PACS 'ID': N s so
  /// far"; retry after 1000 ms). A cached series whose instance count changed on the PACS is queued again and its
  /// cached store returned meanwhile. A prep that failed throws its error
  /// once (std::runtime_error naming the PACS and the series); the next call queues it again. Throws
  /// std::out_of_range for a name no listing of its PACS holds and the cache does not have.
  std::filesystem::path resolve(const std::string& name);
  /// What operators and viewers see: per PACS its id, URL, last listing (time, series, error), and each series'
  /// name, modality, description, instances, study and state (cached, fetching, queued, failed, remote); patient
  /// fields only where patient_fields is set. `visible` filters the series (empty: all).
  nlohmann::json toJson(const std::function<bool(const std::string&)>& visible = {}) const;

  /// The cache folder.
  const std::filesystem::path& cacheDir() const { return mCache.dir; }

 private:
  struct Listed {
    std::string pacs;
    store::QidoSeries series;
  };
  struct Pacs {
    PacsConfig config;
    std::map<std::string, Listed> series;  ///< by dataset name, at the last listing that succeeded
    std::chrono::system_clock::time_point listedAt{};
    std::string error;  ///< of the last listing; empty when it succeeded
    std::chrono::steady_clock::time_point nextListing{};
  };
  struct Job {
    std::string name;
    /// The last request of the series: a job nobody asked for again within mAbandonedAfter (its clients retry
    /// Busy every second) is dropped before it starts, so series a viewer skipped past do not hold up the one it
    /// stopped on.
    std::chrono::steady_clock::time_point askedAt, startedAt{};
    bool running = false;
  };

  void listingLoop();
  /// Lists each PACS whose listing is due (`all`: each one).
  void list(bool all);
  void prepLoop();
  void prepare(const std::string& name);
  /// The instance count the cached store of `name` was prepped from (-2: its record unreadable); -1 when none is
  /// cached. From memory: the records are read once, when the catalog starts.
  int64_t cachedInstances(const std::string& name) const;
  /// Moves the least recently opened stores (never `keep`, nor one queued) out of the cache until it fits: into
  /// scratch folders, whose paths it returns for the caller to delete without holding the lock.
  std::vector<std::filesystem::path> evict(const std::string& keep);
  const Pacs* pacsOf(const std::string& name) const;

  const PacsCacheConfig mCache;
  const std::filesystem::path mVoxbrick;
  const std::chrono::milliseconds mAbandonedAfter;
  Lister mLister;
  Prepper mPrepper;

  mutable std::mutex mMutex;
  std::condition_variable mWake;
  std::vector<Pacs> mPacs;
  std::deque<Job> mQueue;  ///< the front one runs
  std::map<std::string, std::string> mFailed;  ///< a prep's error, told once
  std::map<std::string, std::chrono::system_clock::time_point> mOpened;  ///< last resolve of each cached store
  std::map<std::string, int64_t> mCached;  ///< each cached store's instance count (cachedInstances)
  std::shared_ptr<PrepProcess> mRunning;  ///< the prep running, to cancel
  bool mStarted = false;
  std::atomic<bool> mStopping{false};
  std::thread mListing, mPreparing;
};

}  // namespace voxbrick::server
