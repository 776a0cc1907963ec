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

}  // namespace

std::vector<QidoInstance> parseQidoInstances(std::string_view json, const std::string& seriesUid,
                                             const std::string& what) {
  const Json results = parseResults(json, what);
  std::vector<QidoInstance> instances;
  std::set<std::string> seen;
  for (size_t i = 0; i < results.size(); ++i) {
    QidoInstance q;
    q.sopInstanceUid = checkedUid(firstValue(results[i], "00080018", i, what), what, i, "SOPInstanceUID");
    q.sopClassUid = firstValue(results[i], "00080016", i, what);
    const std::string series = firstValue(results[i], "0020000E", i, what);
    if (!series.empty() && series != seriesUid)
      throw InputError(what + ": result " + std::to_string(i + 1) + " (instance " + q.sopInstanceUid +
                       ") is of series " + series.substr(0, 80) + ", not " + seriesUid);
    if (seen.insert(q.sopInstanceUid).second) instances.push_back(std::move(q));
  }
  return instances;
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
