// The PACS catalog on its own, with a scripted PACS (a listing function) and a scripted prep (files written where a
// store goes): names, Busy until prepped, a failed prep told once, the cache's eviction by last open, a changed
// series fetched again while the cached one serves, a PACS that cannot be listed, patient fields only when asked.
// tests/dicomweb/test_pacs_server.cpp runs the same against a real Orthanc and the real server.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>

#include "server/ErrorReply.h"
#include "server/PacsCatalog.h"
#include "support/TestSupport.h"

namespace voxbrick::server {
namespace {

namespace fs = std::filesystem;
using proto::ErrorCode;

store::QidoSeries series(const std::string& uid, int64_t instances, const std::string& modality = "CT") {
  store::QidoSeries s;
  s.seriesUid = uid;
  s.studyUid = "1.9";
  s.modality = modality;
  s.description = "series " + uid;
  s.instances = instances;
  s.patientName = "Doe^Jane";
  s.patientId = "P-77";
  return s;
}

PacsConfig pacs(const std::string& id, bool patientFields = false) {
  PacsConfig p;
  p.id = id;
  p.url = "http://127.0.0.1:1/dicom-web";
  p.patientFields = patientFields;
  p.refreshS = 3600;
  return p;
}

/// A PACS whose listing and preps the test decides.
struct ScriptedPacs {
  std::mutex mutex;
  std::vector<store::QidoSeries> listing;
  std::string listingError;  ///< thrown by the listing when set
  std::string prepError;     ///< thrown by a prep when set
  size_t storeBytes = 700 << 10;
  std::atomic<int> preps{0};
  std::atomic<bool> hold{false};  ///< a prep waits while set

  PacsCatalog::Lister lister() {
    return [this](const PacsConfig&, const std::function<bool()>&) {
      std::lock_guard lock(mutex);
      if (!listingError.empty()) throw std::runtime_error(listingError);
      return listing;
    };
  }
  PacsCatalog::Prepper prepper() {
    return [this](const PacsConfig&, const store::QidoSeries& s, const fs::path& out, const fs::path&, PrepProcess&) {
      while (hold) std::this_thread::sleep_for(std::chrono::milliseconds(5));
      ++preps;
      {
        std::lock_guard lock(mutex);
        if (!prepError.empty()) throw std::runtime_error(prepError);
      }
      fs::create_directories(out);
      std::ofstream(out / "store.json") << "{\"series\": \"" << s.seriesUid << "\", \"instances\": " << s.instances
                                        << "}";
      std::ofstream(out / "bricks.bin") << std::string(storeBytes, 'b');
    };
  }
};

/// What resolve() throws, as the server answers it.
proto::Error refusal(PacsCatalog& catalog, const std::string& name) {
  try {
    catalog.resolve(name);
  } catch (...) {
    return errorReply(std::current_exception());
  }
  ADD_FAILURE() << name << " resolved";
  return {};
}

/// Resolves `name` until it is ready (Busy meanwhile), within 10 s.
fs::path ready(PacsCatalog& catalog, const std::string& name) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (true) {
    try {
      return catalog.resolve(name);
    } catch (const proto::ProtocolError& e) {
      if (e.code() != ErrorCode::Busy || std::chrono::steady_clock::now() > deadline) throw;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

class PacsCatalogTest : public ::testing::Test {
 protected:
  test::ScratchDir dir;
  ScriptedPacs remote;
  PacsCacheConfig cache() {
    PacsCacheConfig c;
    c.dir = dir / "cache";
    c.maxMB = 2;  // two stores of 700 KiB (and their small files) fit; a third does not
    return c;
  }
  std::unique_ptr<PacsCatalog> catalog(std::vector<PacsConfig> p = {pacs("orthanc")}) {
    return std::make_unique<PacsCatalog>(p, cache(), "/nonexistent/voxbrick", remote.lister(), remote.prepper());
  }
};

TEST_F(PacsCatalogTest, ImageSeriesAreListedAndPreppedWhenFirstOpened) {
  // What the listing gives is listed (which series hold images is the listing's to judge: searchImageSeries).
  remote.listing = {series("1.1", 10), series("1.2", 3, "MR")};
  auto c = catalog();
  c->refresh();
  EXPECT_EQ(c->names(), (std::vector<std::string>{"orthanc.1.1", "orthanc.1.2"}));
  EXPECT_TRUE(c->owns("orthanc.1.9"));
  EXPECT_FALSE(c->owns("other.1.1"));
  EXPECT_FALSE(c->owns("orthanc"));
  c->start();
  const proto::Error busy = refusal(*c, "orthanc.1.1");
  EXPECT_EQ(busy.code, ErrorCode::Busy);
  EXPECT_NE(busy.message.find("series 1.1 of PACS 'orthanc' (10 instances)"), std::string::npos) << busy.message;
  EXPECT_EQ(proto::retryAfterMs(busy.message), 1000u);
  const fs::path store = ready(*c, "orthanc.1.1");
  EXPECT_EQ(store, dir / "cache" / "orthanc.1.1");
  EXPECT_TRUE(fs::exists(store / "store.json"));
  EXPECT_EQ(remote.preps, 1);
  EXPECT_EQ(c->resolve("orthanc.1.1"), store);  // cached: no second prep
  EXPECT_EQ(remote.preps, 1);
  // Nothing of the prep is left beside the store but its sidecar.
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir / "cache")) files.push_back(e.path().filename().string());
  std::sort(files.begin(), files.end());
  EXPECT_EQ(files, (std::vector<std::string>{"orthanc.1.1", "orthanc.1.1.json"}));
  std::string what;
  try {
    c->resolve("orthanc.7.7");
  } catch (const std::out_of_range& e) {
    what = e.what();
  }
  EXPECT_NE(what.find("no series 7.7 in PACS 'orthanc'"), std::string::npos) << what;
  // Stats: each series' state; no patient field unless configured.
  const nlohmann::json j = c->toJson();
  ASSERT_EQ(j.size(), 1u);
  EXPECT_EQ(j[0]["id"], "orthanc");
  EXPECT_TRUE(j[0]["error"].is_null());
  ASSERT_EQ(j[0]["series"].size(), 2u);
  EXPECT_EQ(j[0]["series"][0]["state"], "cached");
  EXPECT_EQ(j[0]["series"][1]["state"], "remote");
  EXPECT_FALSE(j[0]["series"][0].contains("patient"));
  EXPECT_EQ(j[0]["series"][0].dump().find("Doe"), std::string::npos);
}

TEST_F(PacsCatalogTest, PatientFieldsAreShownOnlyWhereConfigured) {
  remote.listing = {series("1.1", 10)};
  auto c = catalog({pacs("ward", true)});
  c->refresh();
  const nlohmann::json s = c->toJson()[0]["series"][0];
  EXPECT_EQ(s["patient"]["name"], "Doe^Jane");
  EXPECT_EQ(s["patient"]["id"], "P-77");
  EXPECT_EQ(c->toJson([](const std::string&) { return false; })[0]["series"].size(), 0u);
}

TEST_F(PacsCatalogTest, AFailedPrepIsToldOnceThenTriedAgain) {
  remote.listing = {series("1.1", 10)};
  remote.prepError = "voxbrick prep failed on series 1.1 of PACS 'orthanc' (exit 1): GET ...: HTTP 401";
  auto c = catalog();
  c->refresh();
  c->start();
  EXPECT_EQ(refusal(*c, "orthanc.1.1").code, ErrorCode::Busy);
  proto::Error error;
  for (int i = 0; i < 1000; ++i) {
    error = refusal(*c, "orthanc.1.1");
    if (error.code != ErrorCode::Busy) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(error.code, ErrorCode::Internal);
  EXPECT_NE(error.message.find("HTTP 401"), std::string::npos) << error.message;
  EXPECT_FALSE(fs::exists(dir / "cache" / "orthanc.1.1"));
  {
    std::lock_guard lock(remote.mutex);
    remote.prepError.clear();
  }
  EXPECT_EQ(refusal(*c, "orthanc.1.1").code, ErrorCode::Busy);  // queued again
  EXPECT_TRUE(fs::exists(ready(*c, "orthanc.1.1") / "store.json"));
}

TEST_F(PacsCatalogTest, TheLeastRecentlyOpenedStoreIsEvictedBeyondTheCacheSize) {
  remote.listing = {series("1.1", 1), series("1.2", 1), series("1.3", 1)};
  auto c = catalog();
  c->refresh();
  c->start();
  ready(*c, "orthanc.1.1");
  ready(*c, "orthanc.1.2");
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  c->resolve("orthanc.1.1");  // opened again: 1.2 is now the least recently opened
  ready(*c, "orthanc.1.3");
  for (int i = 0; i < 500 && fs::exists(dir / "cache" / "orthanc.1.2"); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_TRUE(fs::exists(dir / "cache" / "orthanc.1.1"));
  EXPECT_FALSE(fs::exists(dir / "cache" / "orthanc.1.2"));
  EXPECT_FALSE(fs::exists(dir / "cache" / "orthanc.1.2.json"));
  EXPECT_TRUE(fs::exists(dir / "cache" / "orthanc.1.3"));
  // Evicted is not gone: opened again, it is fetched again.
  EXPECT_EQ(refusal(*c, "orthanc.1.2").code, ErrorCode::Busy);
}

TEST_F(PacsCatalogTest, AChangedSeriesIsFetchedAgainWhileTheCachedOneServes) {
  remote.listing = {series("1.1", 10)};
  auto c = catalog();
  c->refresh();
  c->start();
  const fs::path store = ready(*c, "orthanc.1.1");
  EXPECT_EQ(remote.preps, 1);
  {
    std::lock_guard lock(remote.mutex);
    remote.listing = {series("1.1", 12)};  // two instances more on the PACS
  }
  c->refresh();
  remote.hold = true;
  EXPECT_EQ(c->resolve("orthanc.1.1"), store);  // served as cached, queued again
  remote.hold = false;
  for (int i = 0; i < 500 && remote.preps < 2; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(remote.preps, 2);
  for (int i = 0; i < 500; ++i) {
    std::ifstream in(dir / "cache" / "orthanc.1.1.json");
    if (nlohmann::json::parse(in, nullptr, false).value("instances", 0) == 12) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::ifstream in(store / "store.json");
  EXPECT_EQ(nlohmann::json::parse(in)["instances"], 12);
  EXPECT_EQ(c->resolve("orthanc.1.1"), store);
  EXPECT_EQ(remote.preps, 2);  // the same count again: no third prep
}

TEST_F(PacsCatalogTest, ASeriesNoLongerAskedForIsNotFetched) {
  // A viewer skipping past 1.2 to 1.3 while 1.1 is fetched: 1.2 is not asked for again and is dropped, 1.3 (asked for
  // every retry) is fetched.
  remote.listing = {series("1.1", 1), series("1.2", 1), series("1.3", 1)};
  auto c = std::make_unique<PacsCatalog>(std::vector<PacsConfig>{pacs("orthanc")}, cache(), "/nonexistent/voxbrick",
                                         remote.lister(), remote.prepper(), std::chrono::milliseconds(300));
  c->refresh();
  c->start();
  remote.hold = true;
  EXPECT_EQ(refusal(*c, "orthanc.1.1").code, ErrorCode::Busy);
  EXPECT_EQ(refusal(*c, "orthanc.1.2").code, ErrorCode::Busy);
  const proto::Error behind = refusal(*c, "orthanc.1.3");
  EXPECT_NE(behind.message.find("waits for 2 series fetched before it"), std::string::npos) << behind.message;
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(700);
  while (std::chrono::steady_clock::now() < until) {
    refusal(*c, "orthanc.1.1");
    refusal(*c, "orthanc.1.3");
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  remote.hold = false;
  ready(*c, "orthanc.1.3");
  EXPECT_EQ(remote.preps, 2);  // 1.1 and 1.3
  EXPECT_FALSE(fs::exists(dir / "cache" / "orthanc.1.2"));
  EXPECT_EQ(c->toJson()[0]["series"][1]["state"], "remote");
}

TEST_F(PacsCatalogTest, APacsThatCannotBeListedKeepsItsCachedSeriesOpen) {
  remote.listing = {series("1.1", 10), series("1.2", 3)};
  {
    auto c = catalog();
    c->refresh();
    c->start();
    ready(*c, "orthanc.1.1");
  }
  // A new server (the cache kept) whose PACS is down: the cached series is listed and opens, the other is not.
  fs::create_directories(dir / "cache" / ".tmp-abc123");  // a prep the last server did not finish
  remote.listingError = "GET http://127.0.0.1:1/dicom-web/series?...: Couldn't connect to server";
  auto c = catalog();
  c->refresh();
  EXPECT_FALSE(fs::exists(dir / "cache" / ".tmp-abc123"));
  EXPECT_EQ(c->names(), std::vector<std::string>{"orthanc.1.1"});
  EXPECT_EQ(c->resolve("orthanc.1.1"), dir / "cache" / "orthanc.1.1");
  std::string what;
  try {
    c->resolve("orthanc.1.2");
  } catch (const std::out_of_range& e) {
    what = e.what();
  }
  EXPECT_NE(what.find("its listing failed: GET http://127.0.0.1:1/dicom-web/series"), std::string::npos) << what;
  EXPECT_NE(c->toJson()[0]["error"].get<std::string>().find("Couldn't connect"), std::string::npos);
}

}  // namespace
}  // namespace voxbrick::server
