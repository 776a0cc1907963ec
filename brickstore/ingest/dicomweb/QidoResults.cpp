// QIDO-RS's DICOM JSON: the few attributes a fetch needs, each checked.
#include "brickstore/ingest/dicomweb/QidoResults.h"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <set>

#include "brickstore/format/Errors.h"
#include "brickstore/ingest/dicomweb/DicomWebUrl.h"

namespace voxbrick::store {
namespace {

using Json = nlohmann::json;

Json parseResults(std::string_view text, const std::string& what) {
  if (text.empty()) return Json::array();  // 204 No Content: nothing matched
  Json j = Json::parse(text, nullptr, false);
  if (j.is_discarded()) throw InputError(what + ": the QIDO-RS answer is not JSON");
  if (!j.is_array()) throw InputError(what + ": the QIDO-RS answer is not a JSON array of results");
  return j;
}

/// The first value of attribute `tag` (eight hex digits) of result `index` as a string; "" when absent or empty.
/// Throws when present in another form than DICOM JSON's {"vr": ..., "Value": [...]}.
std::string firstValue(const Json& result, const char* tag, size_t index, const std::string& what) {
  const std::string where = what + ": result " + std::to_string(index + 1) + ", attribute " + tag;
  if (!result.is_object()) throw InputError(what + ": result " + std::to_string(index + 1) + " is not a JSON object");
  const auto it = result.find(tag);
  if (it == result.end()) return "";
  if (!it->is_object()) throw InputError(where + " is not a DICOM JSON attribute object");
  const auto value = it->find("Value");
  if (value == it->end()) return "";
  if (!value->is_array()) throw InputError(where + ": 'Value' is not an array");
  if (value->empty()) return "";
  const Json& v = value->front();
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_integer()) return std::to_string(v.get<int64_t>());
  if (v.is_null()) return "";
  throw InputError(where + ": its first value is neither a string nor an integer");
}

/// The alphabetic form of person name `tag` (DICOM JSON's {"Alphabetic": ...}, PS3.18 F.2.2) of result `index`; ""
/// when absent.
std::string personName(const Json& result, const char* tag, size_t index, const std::string& what) {
  const auto it = result.find(tag);
  if (it == result.end() || !it->is_object()) return "";
  const auto value = it->find("Value");
  if (value == it->end() || !value->is_array() || value->empty()) return "";
  const Json& v = value->front();
  if (v.is_object() && v.contains("Alphabetic") && v["Alphabetic"].is_string()) return v["Alphabetic"];
  if (v.is_string()) return v.get<std::string>();
  if (v.is_object() || v.is_null()) return "";
  throw InputError(what + ": result " + std::to_string(index + 1) + ", attribute " + tag +
                   ": its first value is not a person name");
}

std::string checkedUid(const std::string& uid, const std::string& what, size_t index, const char* name) {
  if (!isDicomUid(uid))
    throw InputError(what + ": result " + std::to_string(index + 1) + " has " +
                     (uid.empty() ? std::string("no ") + name
                                  : std::string(name) + " '" + uid.substr(0, 80) +
                                        "', which is not a DICOM UID (digits and dots, at most 64)"));
  return uid;
}

/// Every result of a series' instance search as listed, duplicates included.
std::vector<QidoInstance> instanceResults(std::string_view json, const std::string& seriesUid,
                                          const std::string& what) {
  const Json results = parseResults(json, what);
  std::vector<QidoInstance> instances;
  for (size_t i = 0; i < results.size(); ++i) {
    QidoInstance q;
    q.sopInstanceUid = checkedUid(firstValue(results[i], "00080018", i, what), what, i, "SOPInstanceUID");
    q.sopClassUid = firstValue(results[i], "00080016", i, what);
    const std::string series = firstValue(results[i], "0020000E", i, what);
    if (!series.empty() && series != seriesUid)
      throw InputError(what + ": result " + std::to_string(i + 1) + " (instance " + q.sopInstanceUid +
                       ") is of series " + series.substr(0, 80) + ", not " + seriesUid);
    instances.push_back(std::move(q));
  }
  return instances;
}

}  // namespace

std::vector<QidoInstance> parseQidoInstances(std::string_view json, const std::string& seriesUid,
                                             const std::string& what) {
  std::vector<QidoInstance> instances;
  std::set<std::string> seen;
  for (QidoInstance& q : instanceResults(json, seriesUid, what))
    if (seen.insert(q.sopInstanceUid).second) instances.push_back(std::move(q));
  return instances;
}

QidoInstancePages::QidoInstancePages(std::string searchUrl, std::string seriesUid, size_t maxBytes, size_t pageSize)
    : mSearchUrl(std::move(searchUrl)),
      mSeriesUid(std::move(seriesUid)),
      mMaxBytes(maxBytes),
      mPageSize(std::max<size_t>(1, pageSize)) {}

std::string QidoInstancePages::nextUrl() const {
  return mSearchUrl + (mSearchUrl.find('?') == std::string::npos ? "?" : "&") + "limit=" + std::to_string(mPageSize) +
         "&offset=" + std::to_string(mOffset);
}

bool QidoInstancePages::add(std::string_view json, const std::string& warning) {
  const std::string what = "GET " + nextUrl();
  mBytes += json.size();
  if (mBytes > mMaxBytes)
    throw InputError(what + ": the search's answers exceed " + std::to_string(mMaxBytes >> 20) + " MB (" +
                     std::to_string(mPages + 1) + " pages of " + std::to_string(mPageSize) + ")");
  ++mPages;
  const std::vector<QidoInstance> page = instanceResults(json, mSeriesUid, what);
  size_t added = 0;
  for (const QidoInstance& q : page)
    if (mSeen.insert(q.sopInstanceUid).second) {
      mInstances.push_back(q);
      ++added;
    }
  if (mOffset > 0 && !page.empty() && added == 0)
    throw InputError(what + ": the server listed again the instances it had listed before (" +
                     std::to_string(page.size()) + " results, all among the " + std::to_string(mInstances.size()) +
                     " listed): it ignores QIDO-RS's offset, so a series of more than " + std::to_string(mOffset) +
                     " instances cannot be listed by it page by page");
  mOffset += page.size();
  if (page.size() > mPageSize) return false;  // `limit` ignored: everything at once
  if (page.size() == mPageSize) return true;
  return !page.empty() && qidoResultsCut(warning);  // a page cut short by the server's own cap: the rest follows
}

bool qidoResultsCut(const std::string& warning) {
  for (size_t start = 0; start < warning.size();) {
    size_t end = warning.find('\n', start);
    if (end == std::string::npos) end = warning.size();
    const std::string line = warning.substr(start, end - start);
    if (line.rfind("299 ", 0) == 0 || line.find(", 299 ") != std::string::npos) return true;
    start = end + 1;
  }
  return false;
}

std::vector<QidoSeries> parseQidoSeries(std::string_view json, const std::string& what) {
  const Json results = parseResults(json, what);
  std::vector<QidoSeries> series;
  std::set<std::string> seen;
  for (size_t i = 0; i < results.size(); ++i) {
    QidoSeries s;
    s.seriesUid = checkedUid(firstValue(results[i], "0020000E", i, what), what, i, "SeriesInstanceUID");
    s.modality = firstValue(results[i], "00080060", i, what);
    s.description = firstValue(results[i], "0008103E", i, what);
    const std::string count = firstValue(results[i], "00201209", i, what);
    if (!count.empty()) {
      if (count.size() > 12 || !std::all_of(count.begin(), count.end(), [](char c) { return c >= '0' && c <= '9'; }))
        throw InputError(what + ": result " + std::to_string(i + 1) + ": NumberOfSeriesRelatedInstances '" +
                         count.substr(0, 20) + "' is not a count");
      s.instances = std::stoll(count);
    }
    s.studyUid = firstValue(results[i], "0020000D", i, what);
    if (!s.studyUid.empty()) checkedUid(s.studyUid, what, i, "StudyInstanceUID");
    s.studyDescription = firstValue(results[i], "00081030", i, what);
    s.studyDate = firstValue(results[i], "00080020", i, what);
    s.patientName = personName(results[i], "00100010", i, what);
    s.patientId = firstValue(results[i], "00100020", i, what);
    s.patientBirthDate = firstValue(results[i], "00100030", i, what);
    if (seen.insert(s.seriesUid).second) series.push_back(std::move(s));
  }
  return series;
}

bool isNonImageModality(std::string_view modality) {
  static const std::set<std::string_view> kNonImage = {"SR",  "KO",  "PR",   "RTPLAN", "RTSTRUCT", "RTRECORD",
                                                       "REG", "DOC", "SEG",  "ECG",    "HD",       "AU",
                                                       "FID", "RWV", "PLAN", "RESP"};
  return kNonImage.count(modality) > 0;
}

}  // namespace voxbrick::store
