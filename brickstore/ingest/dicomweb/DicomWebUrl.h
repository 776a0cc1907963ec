// A DICOMweb input named as dicomweb[s]://HOST[:PORT]/PATH/studies/STUDY[/series/SERIES]: the service's base URL
// and the UIDs, and the QIDO-RS and WADO-RS resources under it.
#pragma once

#include <string>
#include <string_view>

namespace voxbrick::store {

/// A parsed dicomweb:// or dicomwebs:// input.
struct DicomWebUrl {
  std::string input;   ///< as given, for messages
  std::string base;    ///< the service's root: "http://HOST:PORT/PATH" (https for dicomwebs), no trailing slash
  std::string study;   ///< the StudyInstanceUID
  std::string series;  ///< the SeriesInstanceUID; "" for a study
  bool https = false;

  /// BASE/studies/STUDY
  std::string studyUrl() const;
  /// BASE/studies/STUDY/series/SERIES (of `seriesUid`, or of the URL's series when empty)
  std::string seriesUrl(const std::string& seriesUid = "") const;
  /// The QIDO-RS search for a study's series: BASE/studies/STUDY/series
  std::string seriesSearchUrl() const;
  /// The QIDO-RS search for a series' instances: SERIES URL/instances
  std::string instancesUrl(const std::string& seriesUid = "") const;
  /// The WADO-RS resource of one instance: SERIES URL/instances/INSTANCE
  std::string instanceUrl(const std::string& seriesUid, const std::string& instanceUid) const;
};

/// Whether `input` names a DICOMweb resource (starts with dicomweb:// or dicomwebs://, in any case).
bool isDicomWebInput(std::string_view input);

/// Parses a dicomweb:// (HTTP) or dicomwebs:// (HTTPS) input. The host is a name, an IPv4 address or an IPv6 address
/// in brackets; the port 1 to 65535; the path before "/studies/" any number of segments (percent-encoded where they
/// need it); the UIDs DICOM UIDs (digits and dots, at most 64 characters). Refused, naming the problem: user
/// information ("user:password@": a secret on the command line; credentials come from a file or the environment), a
/// query or fragment, a path that does not end in /studies/UID or /studies/UID/series/UID.
DicomWebUrl parseDicomWebUrl(const std::string& input);

/// Whether `uid` is a DICOM UID: 1 to 64 characters of digits and dots, no empty component.
bool isDicomUid(std::string_view uid);

}  // namespace voxbrick::store
