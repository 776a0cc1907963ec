// QIDO-RS results (application/dicom+json, DICOM PS3.18 F.2): the instances of a series and the series of a study,
// read from the JSON a server answered, every value checked before it names a file or a URL.
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace voxbrick::store {

/// One instance a series search listed.
struct QidoInstance {
  std::string sopInstanceUid;  ///< (0008,0018)
  std::string sopClassUid;     ///< (0008,0016); "" when not listed
};

/// One series a study search (or a search of every series) listed.
struct QidoSeries {
  std::string seriesUid;    ///< (0020,000E)
  std::string modality;     ///< (0008,0060); "" when not listed
  std::string description;  ///< (0008,103E); "" when not listed
  int64_t instances = -1;   ///< (0020,1209) NumberOfSeriesRelatedInstances; -1 when not listed
  std::string studyUid;     ///< (0020,000D); "" when not listed, else a DICOM UID
  std::string studyDescription;  ///< (0008,1030)
  std::string studyDate;         ///< (0008,0020), YYYYMMDD as listed
  std::string patientName;       ///< (0010,0010), its alphabetic form ("Doe^John")
  std::string patientId;         ///< (0010,0020)
  std::string patientBirthDate;  ///< (0010,0030)
};

/// The instances in a QIDO-RS answer for SERIES/instances: a JSON array of objects, each with a SOPInstanceUID that is
/// a DICOM UID; a SeriesInstanceUID, when listed, must be `seriesUid`. Duplicates are listed once. `what` names the
/// request in errors (InputError: not JSON, not an array, a missing or malformed UID, another series).
std::vector<QidoInstance> parseQidoInstances(std::string_view json, const std::string& seriesUid,
                                             const std::string& what);

/// The results a QIDO-RS search asks a server for at a time (its `limit`).
inline constexpr size_t kQidoPageSize = 500;

/// A series' instances searched page by page (PS3.18 8.3.4.4: `limit` and `offset`), for a server that caps the
/// results it gives at once: each page asks for the results after those received so far, until one brings fewer than
/// asked without a Warning 299 ("The number of results exceeded the maximum supported by the server": a page cut
/// short, the search goes on). An instance listed twice counts once. A server that ignores `offset` (a page of
/// nothing but instances already listed) is refused rather than asked again; one that ignores `limit` (more results
/// than asked) has answered everything at once. The answers together are bounded by `maxBytes`.
class QidoInstancePages {
 public:
  QidoInstancePages(std::string searchUrl, std::string seriesUid, size_t maxBytes, size_t pageSize = kQidoPageSize);
  /// The URL of the next page: SEARCH?limit=N&offset=M.
  std::string nextUrl() const;
  /// Takes the answer to nextUrl(): its body and its Warning headers ("" when none). Returns whether another page is
  /// to be asked for. Throws InputError naming the page's URL: a malformed answer (parseQidoInstances), an offset
  /// ignored, the answers beyond maxBytes.
  bool add(std::string_view json, const std::string& warning);
  /// The instances listed so far, each once, in the order listed.
  const std::vector<QidoInstance>& instances() const { return mInstances; }
  /// The pages asked for so far.
  size_t pages() const { return mPages; }
  /// The bytes the answers may still take.
  size_t bytesLeft() const { return mMaxBytes - mBytes; }

 private:
  std::string mSearchUrl, mSeriesUid;
  size_t mMaxBytes, mPageSize, mOffset = 0, mBytes = 0, mPages = 0;
  std::vector<QidoInstance> mInstances;
  std::set<std::string> mSeen;
};

/// Whether Warning headers (one a line, HttpClient::warning) hold a 299, the code a DICOMweb server gives a search
/// it cut short ("The number of results exceeded the maximum supported by the server").
bool qidoResultsCut(const std::string& warning);

/// The series in a QIDO-RS answer for STUDY/series: as parseQidoInstances, each with a SeriesInstanceUID.
std::vector<QidoSeries> parseQidoSeries(std::string_view json, const std::string& what);

/// Whether a series of this Modality holds no images a volume is made of (structured reports, key objects,
/// presentation states, RT plans, structure sets and records, registrations, documents, segmentations, waveforms):
/// for a server whose instance listings give no SOP class (dicomNonImageKind judges those that do).
bool isNonImageModality(std::string_view modality);

}  // namespace voxbrick::store
