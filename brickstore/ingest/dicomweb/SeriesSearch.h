// QIDO-RS searches: a series' instances page by page (what a fetch lists, DicomWebFetch), and every series of a
// service (GET ROOT/series), what a server that lists a PACS as datasets shows (server/PacsCatalog).
#pragma once

#include <string>
#include <vector>

#include "brickstore/ingest/dicomweb/HttpClient.h"
#include "brickstore/ingest/dicomweb/QidoResults.h"

namespace voxbrick::store {

/// The most the answers of one search may take together (tens of thousands of instances or series).
inline constexpr size_t kMaxQidoBytes = size_t(64) << 20;

/// A 2xx body kept whole, up to a bound: a QIDO-RS answer.
class QidoBody final : public ResponseHandler {
 public:
  /// `what` names the request in errors ("GET URL"); `limit` bounds the body.
  QidoBody(std::string what, size_t limit) : mWhat(std::move(what)), mLimit(limit) {}
  void begin(const std::string& contentType) override;
  void data(const char* bytes, size_t size) override;
  /// QIDO-RS's JSON: a body of another type (an HTML sign-in page a proxy put in the way) is refused naming it.
  void end() override;
  const std::string& text() const { return mText; }

 private:
  std::string mWhat, mText, mContentType;
  size_t mLimit;
};

/// The instances of series `seriesUid` that `instancesUrl` (.../series/SERIES/instances) lists, searched page by page
/// (QidoInstancePages), the answers together within kMaxQidoBytes.
std::vector<QidoInstance> searchInstances(HttpClient& client, const std::string& instancesUrl,
                                          const std::string& seriesUid);

/// The series of the DICOMweb root `root` (http[s]://HOST[:PORT]/PATH), with their study, modality, description,
/// instance count, study description and date and patient fields (PatientName, PatientID, PatientBirthDate: the
/// caller decides whether to show them). Asked `pageSize` at a time (`limit`, `offset`) until a page brings fewer
/// without a Warning 299 (a page the server cut short);
/// a server that ignores `offset` (a page of series already listed) is refused by name, as is one whose answers pass
/// 64 MB together. Throws HttpError ("GET URL: ... HTTP 401") or InputError.
std::vector<QidoSeries> searchAllSeries(const std::string& root, const HttpOptions& options,
                                        size_t pageSize = kQidoPageSize);

/// The series of `root` that hold images, as searchAllSeries lists them. A series whose Modality is an image's is
/// one; a series whose Modality is a report's, a plan's, ... (isNonImageModality) is one only if its instances' SOP
/// classes, searched (QIDO-RS, page by page), include an image's: a server may take a series' Modality from the first
/// instance it stored, a report filed in the series say. Such a series' modality is then given as "" (not known).
std::vector<QidoSeries> searchImageSeries(const std::string& root, const HttpOptions& options);

}  // namespace voxbrick::store
