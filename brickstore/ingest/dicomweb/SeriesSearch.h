// Every series of a DICOMweb service (QIDO-RS GET ROOT/series), page by page: what a server that lists a PACS as
// datasets shows (server/PacsCatalog).
#pragma once

#include <string>
#include <vector>

#include "brickstore/ingest/dicomweb/HttpClient.h"
#include "brickstore/ingest/dicomweb/QidoResults.h"

namespace voxbrick::store {

/// The series of the DICOMweb root `root` (http[s]://HOST[:PORT]/PATH), with their study, modality, description,
/// instance count, study description and date and patient fields (PatientName, PatientID, PatientBirthDate: the
/// caller decides whether to show them). Asked `pageSize` at a time (`limit`, `offset`) until a page brings fewer
/// without a Warning 299 (a page the server cut short);
/// a server that ignores `offset` (a page of series already listed) is refused by name, as is one whose answers pass
/// 64 MB together. Throws HttpError ("GET URL: ... HTTP 401") or InputError.
std::vector<QidoSeries> searchAllSeries(const std::string& root, const HttpOptions& options, size_t pageSize = 500);

/// The series of `root` that hold images, as searchAllSeries lists them. A series whose Modality is an image's is
/// one; a series whose Modality is a report's, a plan's, ... (isNonImageModality) is one only if its instances' SOP
/// classes, searched (QIDO-RS, page by page), include an image's: a server may take a series' Modality from the first
/// instance it stored, a report filed in the series say. Such a series' modality is then given as "" (not known).
std::vector<QidoSeries> searchImageSeries(const std::string& root, const HttpOptions& options);

}  // namespace voxbrick::store
