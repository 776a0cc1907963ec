// A series from a DICOMweb server: listed (QIDO-RS), then fetched (WADO-RS) by a few connections at once, each
// instance's multipart answer streamed into its own file.
#include "brickstore/ingest/dicomweb/DicomWebFetch.h"

#include <stdlib.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>
#include <tuple>

#include "brickstore/format/Errors.h"
#include "brickstore/ingest/dicomweb/DicomWebUrl.h"
#include "brickstore/ingest/dicomweb/HttpClient.h"
#include "brickstore/ingest/dicomweb/Multipart.h"
#include "brickstore/ingest/dicomweb/QidoResults.h"
#include "brickstore/ingest/dicomweb/SeriesSearch.h"
#include "brickstore/source/DicomClasses.h"
#include "common/Units.h"

namespace voxbrick::store {
namespace {

namespace fs = std::filesystem;

constexpr const char* kJson = "application/dicom+json";
// transfer-syntax=*: each instance as the server keeps it, so the files are the ones it was given.
constexpr const char* kWadoAccept = "multipart/related; type=\"application/dicom\"; transfer-syntax=*";

/// A 2xx body read and dropped: only the status counts.
class BodyDiscarded final : public ResponseHandler {
 public:
  void begin(const std::string&) override {}
  void data(const char*, size_t) override {}
  void end() override {}
};

/// One WADO-RS instance: its multipart answer's one part, application/dicom, streamed into FILE.part and renamed to
/// FILE once the closing boundary has been read.
class InstanceFile final : public ResponseHandler, private PartHandler {
 public:
  explicit InstanceFile(fs::path path) : mPath(std::move(path)), mPartial(mPath.string() + ".part") {}
  ~InstanceFile() override { closeFile(); }

  void begin(const std::string& contentType) override {
    const MultipartType type = parseMultipartType(contentType);
    if (!type.type.empty() && type.type != "application/dicom")
      throw MultipartError("the answer is multipart/related of type '" + type.type + "', not application/dicom", false);
    mFile = std::fopen(mPartial.c_str(), "wb");
    if (mFile == nullptr) throw IoError(errnoMessage("cannot create " + mPartial.string()));
    mParser.emplace(type.boundary, static_cast<PartHandler&>(*this));
  }
  void data(const char* bytes, size_t size) override { mParser->feed(bytes, size); }
  void end() override {
    mParser->finish();
    if (mParser->parts() != 1)
      throw MultipartError("the answer holds " + std::to_string(mParser->parts()) + " parts, not one instance", false);
    if (std::fflush(mFile) != 0) throw IoError(errnoMessage("cannot write " + mPartial.string()));
    closeFile();
    std::error_code ec;
    fs::rename(mPartial, mPath, ec);
    if (ec)
      throw IoError("cannot rename " + mPartial.string() + " to " + mPath.filename().string() + ": " + ec.message());
  }
  void abandon() override {
    closeFile();
    std::error_code ec;
    fs::remove(mPartial, ec);
    mParser.reset();
  }

 private:
  void partBegin(const PartHeaders& headers) override {
    if (mParser->parts() > 1) throw MultipartError("the answer holds more than one part for one instance", false);
    const std::string type = headerValue(headers, "content-type");
    const std::string media = type.substr(0, type.find(';'));
    std::string lower(media.size(), ' ');
    std::transform(media.begin(), media.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    while (!lower.empty() && lower.back() == ' ') lower.pop_back();
    if (!type.empty() && lower != "application/dicom")
      throw MultipartError("its part is '" + type.substr(0, 80) + "', not application/dicom", false);
  }
  void partData(const char* bytes, size_t size) override {
    if (std::fwrite(bytes, 1, size, mFile) != size) throw IoError(errnoMessage("cannot write " + mPartial.string()));
  }
  void partEnd() override {}

  void closeFile() {
    if (mFile != nullptr && std::fclose(mFile) != 0 && mParser) {
      // A failed close after a flush that succeeded loses nothing here: end() flushed before closing.
    }
    mFile = nullptr;
  }

  fs::path mPath, mPartial;
  std::FILE* mFile = nullptr;
  std::optional<MultipartParser> mParser;
};

/// The instances QIDO-RS lists for a series (maybe none), page by page (QidoInstancePages).
std::vector<QidoInstance> searchInstances(HttpClient& client, const DicomWebUrl& url, const std::string& seriesUid) {
  return store::searchInstances(client, url.instancesUrl(seriesUid), seriesUid);
}

/// The instances of a series the server counts (NumberOfSeriesRelatedInstances in its series search); -1 when it
/// does not say, or does not answer a search by SeriesInstanceUID (a 4xx).
int64_t countedInstances(HttpClient& client, const DicomWebUrl& url, const std::string& seriesUid) {
  const std::string search = url.seriesSearchUrl() + "?SeriesInstanceUID=" + seriesUid;
  QidoBody body("GET " + search, kMaxQidoBytes);
  try {
    client.get(search, kJson, body);
  } catch (const HttpError& e) {
    if (e.status() >= 400 && e.status() < 500) return -1;
    throw;
  }
  for (const QidoSeries& s : parseQidoSeries(body.text(), "GET " + search))
    if (s.seriesUid == seriesUid) return s.instances;
  return -1;
}

/// A series' instances when its search listed fewer than the server counts: a server may cap a search's results
/// whatever its offset (Orthanc's LimitFindInstances: the plugin pages within the first LIMIT + 1 results and
/// says nothing), so the series' WADO-RS metadata, which lists every instance, is read instead. Throws when it too
/// lists fewer.
std::vector<QidoInstance> completeInstances(HttpClient& client, const DicomWebUrl& url, const std::string& seriesUid,
                                            std::vector<QidoInstance> listed, int64_t counted) {
  if (counted < 0 || int64_t(listed.size()) >= counted) return listed;
  const std::string metadata = url.seriesUrl(seriesUid) + "/metadata";
  QidoBody body("GET " + metadata, kMaxQidoBytes);
  client.get(metadata, kJson, body);
  std::vector<QidoInstance> all = parseQidoInstances(body.text(), seriesUid, "GET " + metadata);
  if (int64_t(all.size()) < counted)
    throw InputError("the series " + seriesUid + " holds " + std::to_string(counted) +
                     " instances (NumberOfSeriesRelatedInstances), but the server's search (GET " +
                     url.instancesUrl(seriesUid) + ") listed " + std::to_string(listed.size()) +
                     " and its metadata (GET " + metadata + ") " + std::to_string(all.size()) +
                     ": does the server cap its search results?");
  return all;
}

/// A study's series as judged for the choice: its instances, how many are images, what the others are.
struct SeriesCensus {
  QidoSeries series;
  std::vector<QidoInstance> instances;
  size_t images = 0;
  std::string notImage;  ///< what its first instance that is no image is ("RT plan"); else its modality
};

/// The series as a table, one per line: UID, modality, description, instances, images (each line after a newline).
std::string seriesTable(const std::vector<SeriesCensus>& series) {
  std::vector<std::vector<std::string>> rows = {{"UID", "modality", "description", "instances", "images"}};
  for (const SeriesCensus& c : series) {
    const QidoSeries& s = c.series;
    std::string description = s.description.empty() ? "-" : s.description;
    if (description.size() > 40) description = description.substr(0, 37) + "...";
    rows.push_back({s.seriesUid, s.modality.empty() ? "-" : s.modality, description, std::to_string(c.instances.size()),
                    std::to_string(c.images)});
  }
  return common::textTable(rows, 3);  // instances and images right-aligned
}

/// An empty search answer means nothing for a resource that does not exist on servers that answer 200 with no
/// results: the resource itself is asked for, so that its 404 is the error. `what` names it ("series UID in study
/// UID"); a resource the server has is refused as empty.
[[noreturn]] void refuseEmpty(HttpClient& client, const std::string& resource, const std::string& what,
                              const std::string& search, const std::string& listed) {
  BodyDiscarded discarded;
  try {
    client.get(resource + "/metadata", kJson, discarded);
  } catch (const HttpError& e) {
    if (e.status() == 404)
      throw InputError("no " + what + ": " + e.what() + " (QIDO-RS GET " + search + " listed no " + listed + ")");
    throw;
  }
  throw InputError("the " + what + " is empty (QIDO-RS GET " + search + " listed no " + listed + ")");
}

/// The series of a study URL to fetch, with its instances: options.seriesUid, else the study's one series that holds
/// images. Each series' instances are listed, and judged by their SOP classes (dicomNonImageKind, as the DICOM
/// reader judges files): a series of reports, plans, structure sets, ... is skipped, whatever its Modality says (a
/// server may take a series' Modality from a report filed in it). Without SOP classes listed, by Modality.
std::pair<std::string, std::vector<QidoInstance>> chooseSeries(HttpClient& client, const DicomWebUrl& url,
                                                               const std::string& wanted) {
  QidoBody body("GET " + url.seriesSearchUrl(), kMaxQidoBytes);
  client.get(url.seriesSearchUrl(), kJson, body);
  const std::vector<QidoSeries> all = parseQidoSeries(body.text(), "GET " + url.seriesSearchUrl());
  if (all.empty()) refuseEmpty(client, url.studyUrl(), "study " + url.study, url.seriesSearchUrl(), "series");
  std::vector<SeriesCensus> census;
  for (const QidoSeries& s : all) {
    if (!wanted.empty() && s.seriesUid != wanted) continue;
    SeriesCensus c{
        s, completeInstances(client, url, s.seriesUid, searchInstances(client, url, s.seriesUid), s.instances), 0, ""};
    bool classes = false;
    for (const QidoInstance& i : c.instances) {
      classes = classes || !i.sopClassUid.empty();
      const std::string kind = dicomNonImageKind(i.sopClassUid);
      if (kind.empty() && !i.sopClassUid.empty()) ++c.images;
      if (!kind.empty() && c.notImage.empty()) c.notImage = kind;
    }
    if (!classes) {
      c.images = isNonImageModality(s.modality) ? 0 : c.instances.size();
      c.notImage = s.modality;
    }
    census.push_back(std::move(c));
  }
  if (!wanted.empty()) {
    if (census.empty()) {
      std::vector<SeriesCensus> listed;
      for (const QidoSeries& s : all) listed.push_back({s, {}, 0, ""});
      throw InputError("the study " + url.study + " holds no series " + wanted +
                       "; it holds (UID, modality, "
                       "description):" +
                       seriesTable(listed));
    }
    return {wanted, std::move(census.front().instances)};
  }
  std::vector<SeriesCensus> images;
  std::string skipped;
  size_t skippedCount = 0;
  for (SeriesCensus& c : census) {
    if (c.images > 0) {
      images.push_back(std::move(c));
      continue;
    }
    if (++skippedCount <= 6)
      skipped += (skipped.empty() ? "" : ", ") + c.series.seriesUid + " (" +
                 (c.notImage.empty() ? std::string("no instances") : c.notImage) + ")";
  }
  if (skippedCount > 6) skipped += " and " + std::to_string(skippedCount - 6) + " more";
  if (!skipped.empty()) skipped = " (skipped, no images: " + skipped + ")";
  if (images.empty()) throw InputError("the study " + url.study + " holds no image series" + skipped);
  if (images.size() > 1)
    throw InputError("the study " + url.study + " holds " + std::to_string(images.size()) +
                     " image series; pick one with --series UID" + skipped + ":" + seriesTable(images));
  return {images.front().series.seriesUid, std::move(images.front().instances)};
}

/// A new folder under `parent` for one fetch.
fs::path makeFetchDirectory(const std::string& parent) {
  std::error_code ec;
  const fs::path base = parent.empty() ? fs::temp_directory_path(ec) : fs::path(parent);
  if (ec) throw IoError("no temporary directory to fetch into: " + ec.message());
  std::string pattern = (base / ".voxbrick-dicomweb-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr)
    throw IoError(errnoMessage("cannot create a folder to fetch into in " + base.string()));
  return pattern;
}

/// Fetches every instance into `directory` with up to options.connections transfers at once; the first failure
/// stops the others and passes out.
void fetchInstances(const DicomWebUrl& url, const std::string& seriesUid, const std::vector<QidoInstance>& instances,
                    const fs::path& directory, const HttpOptions& http, const DicomWebOptions& options,
                    FetchedSeries& fetched) {
  const size_t count = instances.size();
  const size_t threads = std::clamp<size_t>(size_t(std::max(1, options.connections)), 1, count);
  std::atomic<size_t> next{0};
  std::atomic<bool> stop{false};
  std::mutex mutex;  // guards the fields below and options.onFetched
  std::exception_ptr failure;
  int64_t done = 0;
  uint64_t bytes = 0;

  HttpOptions each = http;
  if (options.maxMBPerSecond > 0)
    each.maxBytesPerSecond = std::max<int64_t>(1, int64_t(options.maxMBPerSecond * 1e6 / double(threads)));
  each.cancelled = [&stop, cancelled = options.cancelled] { return stop.load() || (cancelled && cancelled()); };

  auto worker = [&] {
    try {
      HttpClient client(each);
      for (size_t i; !stop && (i = next++) < count;) {
        const std::string& uid = instances[i].sopInstanceUid;
        InstanceFile file(directory / (uid + ".dcm"));
        const uint64_t before = client.bytesReceived();
        client.get(url.instanceUrl(seriesUid, uid), kWadoAccept, file);
        std::lock_guard lock(mutex);
        ++done;
        bytes += client.bytesReceived() - before;
        if (options.onFetched) options.onFetched(done, int64_t(count), bytes);
      }
    } catch (...) {
      std::lock_guard lock(mutex);
      if (!failure) failure = std::current_exception();
      stop = true;
    }
  };
  std::vector<std::thread> pool;
  for (size_t t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
  fetched.instances = done;
  fetched.bytesReceived = bytes;
}

std::unique_ptr<FetchedSeries> fetch(const DicomWebUrl& url, const SourceOptions& options) {
  const DicomWebOptions& o = options.dicomWeb;
  if (!o.caFile.empty() && !fs::is_regular_file(o.caFile))
    throw InputError(o.caFile + ": no such file (--ca: the certificates to trust, PEM)");
  if (!o.caFile.empty() && !url.https)
    throw InputError("--ca applies to dicomwebs:// (HTTPS); " + url.input + " is plain HTTP");
  HttpOptions http;
  http.caFile = o.caFile;
  http.credentials = readHttpCredentials(o.authFile);
  http.timeoutSeconds = o.timeoutSeconds;
  http.retries = o.retries;
  http.cancelled = o.cancelled;
  HttpClient client(http);

  std::string seriesUid = url.series;
  std::vector<QidoInstance> instances;
  if (seriesUid.empty()) {
    std::tie(seriesUid, instances) = chooseSeries(client, url, options.seriesUid);
  } else if (!options.seriesUid.empty() && options.seriesUid != seriesUid) {
    throw InputError("--series " + options.seriesUid + " differs from the series the URL names (" + seriesUid + ")");
  } else {
    instances = searchInstances(client, url, seriesUid);
    if (!instances.empty())
      instances =
          completeInstances(client, url, seriesUid, std::move(instances), countedInstances(client, url, seriesUid));
  }
  if (instances.empty())
    refuseEmpty(client, url.seriesUrl(seriesUid), "series " + seriesUid + " in study " + url.study,
                url.instancesUrl(seriesUid), "instance");

  auto fetched = std::make_unique<FetchedSeries>(makeFetchDirectory(o.downloadDir), url.input, seriesUid);
  fetchInstances(url, seriesUid, instances, fetched->directory(), http, o, *fetched);
  return fetched;
}

}  // namespace

FetchedSeries::FetchedSeries(fs::path directory, std::string input, std::string seriesUid)
    : mDirectory(std::move(directory)), mInput(std::move(input)), mSeriesUid(std::move(seriesUid)) {}

FetchedSeries::~FetchedSeries() {
  std::error_code ec;
  fs::remove_all(mDirectory, ec);
}

std::unique_ptr<FetchedSeries> fetchDicomWebSeries(const std::string& input, const SourceOptions& options) {
  const DicomWebUrl url = parseDicomWebUrl(input);
  try {
    return fetch(url, options);
  } catch (const InputError& e) {
    const std::string message = e.what();
    if (message.find(input) != std::string::npos) throw;
    throw InputError(input + ": " + message);
  }
}

}  // namespace voxbrick::store
