// `voxbrick prep dicomweb://...` against a real PACS: Debian's Orthanc with its DICOMweb plugin, started on loopback
// with authentication on, the cases of tests/brickstore/dicom_cases.py (pacs) uploaded through its REST API. A
// series (with an RT plan and a report filed in it), a study, an Enhanced CT file: each gives the store its files give;
// wrong credentials, a missing series, nothing listening, a cut transfer, an interruption and an untrusted certificate
// are refused by name and leave no store and no fetched file behind.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "Processes.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

namespace fs = std::filesystem;
using test::ChildProcess;
using test::OrthancServer;
using test::runShell;
using test::runVoxbrick;
using test::ScratchDir;

/// The store's files, one SHA-256 line each (bench/store_digest.sh: the OpenVDB files' random UUIDs masked).
std::string digest(const fs::path& store) {
  const auto r =
      runShell("bash '" + std::string(VOXBRICK_SOURCE_DIR) + "/bench/store_digest.sh' '" + store.string() + "'");
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("store.json"), std::string::npos) << r.output;
  return r.output;
}

/// What a fetch may leave beside the output: its folder (.voxbrick-dicomweb-*), which it must remove.
std::vector<std::string> leftovers(const fs::path& dir) {
  std::vector<std::string> found;
  if (!fs::exists(dir)) return found;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind(".voxbrick-dicomweb-", 0) == 0) found.push_back(e.path().string());
  return found;
}

/// Whether a fetch has started writing an instance under `dir` (a .part file with bytes in it).
bool transferStarted(const fs::path& dir) {
  for (const std::string& fetch : leftovers(dir))
    for (const auto& e : fs::directory_iterator(fetch))
      if (e.path().extension() == ".part" && e.file_size() > 0) return true;
  return false;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

#define EXPECT_SAYS(text, part) EXPECT_TRUE(contains(text, part)) << "missing '" << (part) << "' in:\n" << (text)

class DicomWebOrthanc : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ::unsetenv("VOXBRICK_DICOMWEB_AUTH");
    sDir = new ScratchDir;
    const fs::path script = fs::path(VOXBRICK_SOURCE_DIR) / "tests" / "brickstore" / "dicom_cases.py";
    const auto r = runShell("/usr/bin/python3 '" + script.string() + "' pacs '" + cases().string() + "' 2>&1");
    ASSERT_EQ(r.exitCode, 0) << "dicom_cases.py pacs (needs Debian's python3-pydicom and numpy):\n" << r.output;
    std::ifstream in(cases() / "uids.json");
    sUids = new nlohmann::json(nlohmann::json::parse(in));
    try {
      sServer = new OrthancServer(*sDir / "orthanc");
      sServer->upload(cases());
    } catch (const std::exception& e) {
      FAIL() << e.what();
    }
    writeAuth(authFile(), sServer->credentials());
  }
  static void TearDownTestSuite() {
    delete sServer;  // kills Orthanc
    sServer = nullptr;
    delete sUids;
    sUids = nullptr;
    delete sDir;
    sDir = nullptr;
  }
  void SetUp() override {
    if (sServer == nullptr) GTEST_SKIP() << "no Orthanc (the suite's set-up failed)";
  }

  static void writeAuth(const fs::path& path, const std::string& text) {
    test::writeFile(path, text + "\n");
    ::chmod(path.c_str(), 0600);
  }
  static fs::path cases() { return *sDir / "cases"; }
  static fs::path authFile() { return *sDir / "auth"; }
  static std::string uid(const std::string& item, const std::string& key) { return (*sUids)[item][key]; }
  /// dicomweb://127.0.0.1:PORT/dicom-web/studies/STUDY[/series/SERIES]
  static std::string url(const std::string& study, const std::string& series = "") {
    return sServer->dicomWeb() + "/studies/" + study + (series.empty() ? "" : "/series/" + series);
  }
  static std::string seriesUrl(const std::string& item) { return url(uid(item, "study"), uid(item, "series")); }
  /// `voxbrick prep INPUT -o OUT` with the server's credentials from the auth file, and `more` options.
  static test::CommandResult prep(const std::string& input, const fs::path& out, const std::string& more = "") {
    return runVoxbrick("prep '" + input + "' -o '" + out.string() + "' --auth-file '" + authFile().string() + "' " +
                       more);
  }
  /// The store that `voxbrick prep FOLDER` writes of the same files (named by SOPInstanceUID, as a fetch names them).
  static std::string folderDigest(const fs::path& folder, const fs::path& out) {
    const auto r = runVoxbrick("prep '" + folder.string() + "' -q -o '" + out.string() + "'");
    EXPECT_EQ(r.exitCode, 0) << r.output;
    return digest(out);
  }
  /// `voxbrick prep` of the big series in the background, slowed to `rate` MB/s so that it is caught mid-transfer.
  static std::unique_ptr<ChildProcess> slowPrep(const std::string& input, const fs::path& out, const std::string& rate,
                                                const std::vector<std::string>& more = {}) {
    std::vector<std::string> argv = {test::voxbrickExe(), "prep",       input, "-o", out.string(), "--auth-file",
                                     authFile().string(), "--max-rate", rate};
    argv.insert(argv.end(), more.begin(), more.end());
    return std::make_unique<ChildProcess>(argv, out.parent_path(), out.parent_path() / "prep.log");
  }
  /// Waits until `dir` holds an instance being written; false after 30 s.
  static bool waitForTransfer(const fs::path& dir, ChildProcess& prep) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (!transferStarted(dir)) {
      if (!prep.running() || std::chrono::steady_clock::now() > until) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }

  static inline ScratchDir* sDir = nullptr;
  static inline OrthancServer* sServer = nullptr;
  static inline nlohmann::json* sUids = nullptr;
};

TEST_F(DicomWebOrthanc, ASeriesGivesTheStoreItsFilesGive) {
  ScratchDir out;
  // The CT series holds an RT plan and a structured report besides its five slices: skipped, as in a folder.
  const auto r = prep(seriesUrl("ct"), out / "ct.vbs");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_SAYS(r.output, "fetch: 7/7");
  EXPECT_SAYS(r.output, "16x16x5");
  EXPECT_EQ(digest(out / "ct.vbs"), folderDigest(cases() / "ct", out / "files.vbs"));
  EXPECT_TRUE(leftovers(out.path()).empty());
  // The same with the credentials in the environment, and one connection.
  const auto env =
      runShell("VOXBRICK_DICOMWEB_AUTH='" + sServer->credentials() + "' " + test::voxbrickExe() + " prep '" +
               seriesUrl("ct") + "' -q --connections 1 -o '" + (out / "env.vbs").string() + "'");
  ASSERT_EQ(env.exitCode, 0) << env.output;
  EXPECT_EQ(digest(out / "env.vbs"), digest(out / "ct.vbs"));
}

TEST_F(DicomWebOrthanc, AnEnhancedMultiFrameFileIsAVolumeOfItsOwn) {
  ScratchDir out;
  const auto r = prep(seriesUrl("enhanced"), out / "e.vbs");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_SAYS(r.output, "multi-frame image");
  EXPECT_SAYS(r.output, "7x5x6");
  EXPECT_EQ(digest(out / "e.vbs"), folderDigest(cases() / "enhanced", out / "files.vbs"));
}

TEST_F(DicomWebOrthanc, AStudyGivesItsOneImageSeriesOrListsThem) {
  ScratchDir out;
  // The CT study: the CT series, an RT plan series and a report series; the plan and report are no images.
  auto r = prep(url(uid("ct", "study")), out / "study.vbs");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(digest(out / "study.vbs"), folderDigest(cases() / "ct", out / "files.vbs"));
  // Two CT series: listed, --series picks one.
  const std::string two = url(uid("two", "study"));
  const std::string a = (*sUids)["two"]["series"][0], b = (*sUids)["two"]["series"][1];
  r = prep(two, out / "two.vbs");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  for (const std::string& w : {std::string("holds 2 image series"), std::string("--series"), a, b})
    EXPECT_SAYS(r.output, w);
  EXPECT_FALSE(fs::exists(out / "two.vbs"));
  r = prep(two, out / "b.vbs", "--series " + b);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(digest(out / "b.vbs"), folderDigest(cases() / "two" / "b", out / "b-files.vbs"));
  r = prep(two, out / "c.vbs", "--series 1.2.3");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "holds no series 1.2.3");
  // A series URL and another --series contradict each other.
  r = prep(seriesUrl("ct"), out / "d.vbs", "--series " + b);
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "differs from the series the URL names");
}

TEST_F(DicomWebOrthanc, ASeriesBeyondTheServersSearchCapIsFetchedWhole) {
  // Orthanc 1.10 with LimitFindInstances (and its DICOMweb plugin 1.7) answers an instance search with its first
  // LIMIT + 1 results and no Warning header; limit and offset page within those, so offset 101 lists nothing. The
  // series search still counts every instance: the fetch sees the shortfall and lists the series' WADO-RS metadata.
  ScratchDir own, out;
  std::unique_ptr<OrthancServer> server;
  try {
    server = std::make_unique<OrthancServer>(own.path(), "\"LimitFindInstances\": 100, \"LimitFindResults\": 100");
    server->upload(cases() / "many");
  } catch (const std::exception& e) {
    FAIL() << e.what();
  }
  writeAuth(out / "auth", server->credentials());
  const std::string series = "/dicom-web/studies/" + uid("many", "study") + "/series/" + uid("many", "series");
  auto listed = [&](const std::string& query) {
    const std::string user = server->credentials().substr(6);  // past "basic "
    const auto r = runShell("curl -sf -u '" + user + "' -H 'Accept: application/dicom+json' 'http://127.0.0.1:" +
                            std::to_string(server->port()) + series + "/instances" + query +
                            "' | /usr/bin/python3 -c 'import json, sys; print(len(json.load(sys.stdin)))'");
    EXPECT_EQ(r.exitCode, 0) << r.output;
    return std::atoi(r.output.c_str());
  };
  EXPECT_EQ(listed(""), 101) << "the cap this test is about";
  EXPECT_EQ(listed("?limit=500&offset=0"), 101);
  EXPECT_EQ(listed("?limit=50&offset=100"), 1) << "offset pages within the capped results";
  const std::string input =
      server->dicomWeb() + "/studies/" + uid("many", "study") + "/series/" + uid("many", "series");
  auto r = runVoxbrick("prep '" + input + "' -o '" + (out / "many.vbs").string() + "' --auth-file '" +
                       (out / "auth").string() + "'");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_SAYS(r.output, "fetch: 160/160");
  EXPECT_SAYS(r.output, "8x8x160");
  EXPECT_EQ(digest(out / "many.vbs"), folderDigest(cases() / "many", out / "files.vbs"));
  // The same from the study's URL: its series search gives the count there.
  r = runVoxbrick("prep '" + server->dicomWeb() + "/studies/" + uid("many", "study") + "' -q -o '" +
                  (out / "study.vbs").string() + "' --auth-file '" + (out / "auth").string() + "'");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(digest(out / "study.vbs"), digest(out / "many.vbs"));
  EXPECT_TRUE(leftovers(out.path()).empty());
}

TEST_F(DicomWebOrthanc, WrongOrMissingCredentialsAreRefusedByName) {
  ScratchDir out;
  writeAuth(out / "wrong", "basic voxbrick:N0tThePassw0rd");
  const auto start = std::chrono::steady_clock::now();
  auto r = runVoxbrick("prep '" + seriesUrl("ct") + "' -o '" + (out / "s.vbs").string() + "' --auth-file '" +
                       (out / "wrong").string() + "'");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "HTTP 401 Unauthorized");
  EXPECT_SAYS(r.output, "the server refused the credentials from --auth-file " + (out / "wrong").string());
  EXPECT_SAYS(r.output, seriesUrl("ct"));
  EXPECT_FALSE(contains(r.output, "N0tThePassw0rd")) << r.output;
  EXPECT_FALSE(contains(r.output, "attempts")) << "a refusal is not retried: " << r.output;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));

  r = runVoxbrick("prep '" + seriesUrl("ct") + "' -o '" + (out / "s.vbs").string() + "'");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "HTTP 401 Unauthorized: the server asks for credentials");
  EXPECT_SAYS(r.output, "--auth-file");

  r = runShell("VOXBRICK_DICOMWEB_AUTH='bearer some.token' " + test::voxbrickExe() + " prep '" + seriesUrl("ct") +
               "' -o '" + (out / "s.vbs").string() + "'");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "refused the credentials from VOXBRICK_DICOMWEB_AUTH");
  EXPECT_FALSE(contains(r.output, "some.token")) << r.output;

  // In the URL, where every user of the machine sees them: refused before anything is sent.
  std::string inUrl = seriesUrl("ct");
  inUrl.insert(inUrl.find("127.0.0.1"), "voxbrick:secret@");
  r = runVoxbrick("prep '" + inUrl + "' -o '" + (out / "s.vbs").string() + "'");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "credentials do not belong in the URL");
  EXPECT_FALSE(fs::exists(out / "s.vbs"));
  EXPECT_TRUE(leftovers(out.path()).empty());
}

TEST_F(DicomWebOrthanc, AMissingSeriesOrStudyIsA404NamingTheUrl) {
  ScratchDir out;
  const std::string missing = url(uid("ct", "study"), "1.2.3.4.5");
  auto r = prep(missing, out / "s.vbs");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "no series 1.2.3.4.5 in study " + uid("ct", "study"));
  EXPECT_SAYS(r.output, "HTTP 404 Not Found");
  EXPECT_SAYS(r.output, missing);
  EXPECT_SAYS(r.output, "/series/1.2.3.4.5/metadata");
  r = prep(url("9.8.7.6"), out / "s.vbs");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "no study 9.8.7.6");
  EXPECT_SAYS(r.output, "HTTP 404 Not Found");
  // A root that is no DICOMweb service's: the search itself is the 404.
  std::string wrongRoot = seriesUrl("ct");
  wrongRoot.replace(wrongRoot.find("/dicom-web/"), 11, "/dicom-wbe/");
  r = prep(wrongRoot, out / "s.vbs");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "/dicom-wbe/studies/" + uid("ct", "study") + "/series/" + uid("ct", "series") +
                            "/instances?limit=500&offset=0: HTTP 404 Not Found");
  EXPECT_FALSE(fs::exists(out / "s.vbs"));
  EXPECT_TRUE(leftovers(out.path()).empty());
}

TEST_F(DicomWebOrthanc, AFailedPrepWithForceKeepsTheStoreThatWasThere) {
  ScratchDir out;
  const std::string before = folderDigest(cases() / "ct", out / "s.vbs");
  const auto r = prep(url(uid("ct", "study"), "1.2.3.4.5"), out / "s.vbs", "--force");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_EQ(digest(out / "s.vbs"), before);
  EXPECT_TRUE(leftovers(out.path()).empty());
}

TEST_F(DicomWebOrthanc, NothingListeningIsRefusedAfterItsRetries) {
  ScratchDir out;
  const std::string closed =
      "dicomweb://127.0.0.1:" + std::to_string(test::freePort()) + "/dicom-web/studies/1.2/series/3.4";
  const auto start = std::chrono::steady_clock::now();
  const auto r = prep(closed, out / "s.vbs", "--retries 2");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "connection refused");
  EXPECT_SAYS(r.output, "(3 attempts)");
  EXPECT_SAYS(r.output, "/dicom-web/studies/1.2/series/3.4/instances");
  EXPECT_GE(seconds, 1.4) << "two retries wait 0.5 s and 1 s";
  EXPECT_LT(seconds, 10);
  EXPECT_FALSE(fs::exists(out / "s.vbs"));
}

TEST_F(DicomWebOrthanc, AnInterruptedFetchLeavesNothing) {
  ScratchDir out;
  auto child = slowPrep(seriesUrl("big"), out / "big.vbs", "1", {"--connections", "2"});
  ASSERT_TRUE(waitForTransfer(out.path(), *child)) << child->log();
  child->signal(SIGINT);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(child->wait(std::chrono::seconds(20)), 1) << child->log();
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(3)) << "a transfer stops when interrupted";
  EXPECT_SAYS(child->log(), "interrupted; nothing was written");
  EXPECT_FALSE(fs::exists(out / "big.vbs"));
  EXPECT_TRUE(leftovers(out.path()).empty()) << leftovers(out.path()).front();
}

TEST_F(DicomWebOrthanc, OrthancKilledMidTransferIsACutTransferAndNoStore) {
  ScratchDir own, out;
  std::unique_ptr<OrthancServer> server;
  try {
    server = std::make_unique<OrthancServer>(own.path());
    server->upload(cases() / "big");
  } catch (const std::exception& e) {
    FAIL() << e.what();
  }
  writeAuth(out / "auth", server->credentials());
  const std::string input = server->dicomWeb() + "/studies/" + uid("big", "study") + "/series/" + uid("big", "series");
  // One connection at 2 MB/s: an 8 MB instance takes four seconds, more than any socket buffer holds.
  auto child = std::make_unique<ChildProcess>(
      std::vector<std::string>{test::voxbrickExe(), "prep", input, "-o", (out / "big.vbs").string(), "--auth-file",
                               (out / "auth").string(), "--connections", "1", "--max-rate", "2", "--retries", "1"},
      out.path(), out / "prep.log");
  ASSERT_TRUE(waitForTransfer(out.path(), *child)) << child->log();
  server->kill();
  EXPECT_EQ(child->wait(std::chrono::seconds(30)), 1) << child->log();
  const std::string log = child->log();
  EXPECT_SAYS(log, input + ": GET " + "http://127.0.0.1:" + std::to_string(server->port()));
  EXPECT_SAYS(log, "/instances/");
  EXPECT_SAYS(log, "the transfer was cut after");
  EXPECT_SAYS(log, "connection refused");  // the retry, once Orthanc is gone
  EXPECT_SAYS(log, "(2 attempts");
  EXPECT_FALSE(fs::exists(out / "big.vbs"));
  EXPECT_TRUE(leftovers(out.path()).empty());
}

TEST_F(DicomWebOrthanc, HttpsChecksTheServersCertificate) {
  ScratchDir tls, out;
  std::unique_ptr<test::TlsForwarder> forwarder;
  try {
    forwarder = std::make_unique<test::TlsForwarder>(tls.path(), sServer->port());
  } catch (const std::exception& e) {
    FAIL() << e.what();
  }
  const std::string input = "dicomwebs://127.0.0.1:" + std::to_string(forwarder->port()) + "/dicom-web/studies/" +
                            uid("ct", "study") + "/series/" + uid("ct", "series");
  auto r = prep(input, out / "s.vbs");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "the server's TLS certificate is not trusted");
  EXPECT_SAYS(r.output, "--ca FILE");
  EXPECT_FALSE(contains(r.output, "attempts")) << "an untrusted certificate is not retried: " << r.output;
  r = prep(input, out / "s.vbs", "--ca '" + forwarder->certificate().string() + "'");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(digest(out / "s.vbs"), folderDigest(cases() / "ct", out / "files.vbs"));
  r = prep(seriesUrl("ct"), out / "p.vbs", "--ca '" + forwarder->certificate().string() + "'");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_SAYS(r.output, "--ca applies to dicomwebs://");
  EXPECT_TRUE(leftovers(out.path()).empty());
}

}  // namespace
}  // namespace voxbrick

namespace voxbrick {
namespace {

/// `voxbrick request ADDRESS ARGS` through the shell, its output and exit status.
test::CommandResult request(const std::string& address, const std::string& args) {
  return runVoxbrick("request " + address + " " + args);
}

// The server lists the PACS ([[pacs]]): its image series are datasets "ID.SERIESUID", the first request of one is
// answered Busy while the server fetches and preps it into its PACS cache, then its frames are those of the store its
// files give; the series without images (the CT study's RT plan and report) are not listed.
TEST_F(DicomWebOrthanc, TheServerListsThePacsAndServesASeriesOnceFetched) {
  ScratchDir work;
  fs::create_directories(work / "datasets");
  const std::string root = sServer->dicomWeb().replace(0, std::string("dicomweb").size(), "http");
  test::writeFile(work / "server.toml", "[server]\ndatasets = \"datasets\"\n[[pacs]]\nid = \"ward\"\nurl = \"" + root +
                                            "\"\nauth_file = \"" + authFile().string() + "\"\nrefresh_s = 2\n");
  ChildProcess serve({test::voxbrickExe(), "serve", "--config", (work / "server.toml").string(), "--port", "0",
                      "--port-file", (work / "port").string(), "--render-threads", "1"},
                     work.path(), work / "serve.log");
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  std::string address;
  while (address.empty() && std::chrono::steady_clock::now() < until) {
    std::ifstream in(work / "port");
    int port = 0;
    if (in >> port && port > 0) address = "127.0.0.1:" + std::to_string(port);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_FALSE(address.empty()) << serve.log();
  const std::string ct = "ward." + uid("ct", "series");
  test::CommandResult listed;
  while (std::chrono::steady_clock::now() < until) {
    listed = request(address, "--list");
    if (contains(listed.output, ct)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_SAYS(listed.output, ct);
  EXPECT_SAYS(listed.output, "ward." + uid("enhanced", "series"));
  EXPECT_FALSE(contains(listed.output, uid("ct", "plan"))) << listed.output;
  EXPECT_FALSE(contains(listed.output, uid("ct", "report"))) << listed.output;

  const std::string frame = "--dataset " + ct + " --orbit 30,20 --size 96x80 --tf hot -o '";
  // While the series is fetched its dataset is Busy, saying where the fetch stands: a request that waits for nothing
  // ends with it; one that waits (`--busy-wait`, 60 s by default) asks again after each hint and gets the frame.
  auto r = request(address, frame + (work / "pacs.png").string() + "' --busy-wait 0");
  EXPECT_NE(r.exitCode, 0);
  EXPECT_SAYS(r.output, "Busy");
  EXPECT_SAYS(r.output, "of PACS 'ward' (7 instances)");
  r = request(address, frame + (work / "pacs.png").string() + "'");
  ASSERT_EQ(r.exitCode, 0) << r.output << serve.log();
  // The cached store is the one the files give, and so is the frame.
  const fs::path cached = work / "datasets" / ".pacs" / ct;
  EXPECT_EQ(digest(cached), folderDigest(cases() / "ct", work / "files.vbs"));
  const auto cli = runVoxbrick("render '" + (work / "files.vbs").string() +
                               "' --orbit 30,20 --size 96x80 --tf hot -q -o '" + (work / "cli.png").string() + "'");
  ASSERT_EQ(cli.exitCode, 0) << cli.output;
  EXPECT_EQ(test::readFile(work / "pacs.png"), test::readFile(work / "cli.png"));
  // Nothing of the fetch is left beside the cache's store and its record.
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(work / "datasets" / ".pacs")) files.push_back(e.path().filename());
  std::sort(files.begin(), files.end());
  EXPECT_EQ(files, (std::vector<std::string>{ct, ct + ".json"}));
  // A series no listing holds is refused as a missing dataset, naming the PACS.
  r = request(address, "--dataset ward.1.2.3.4 -o '" + (work / "x.png").string() + "'");
  EXPECT_NE(r.exitCode, 0);
  EXPECT_SAYS(r.output, "no series 1.2.3.4 in PACS 'ward'");
}

}  // namespace
}  // namespace voxbrick
