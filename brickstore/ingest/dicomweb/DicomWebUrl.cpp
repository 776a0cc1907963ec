// dicomweb[s]:// inputs: parsed and checked before anything is sent.
#include "brickstore/ingest/dicomweb/DicomWebUrl.h"

#include <algorithm>
#include <cctype>
#include <vector>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

std::string lowerText(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return out;
}

[[noreturn]] void badUrl(const std::string& input, const std::string& why) {
  throw InputError(input + ": " + why +
                   " (expected dicomweb[s]://HOST[:PORT]/PATH/studies/STUDY_UID/series/SERIES_UID, or "
                   ".../studies/STUDY_UID for a study)");
}

bool isHostChar(unsigned char c) { return std::isalnum(c) || c == '-' || c == '.' || c == '_'; }

/// RFC 3986's unreserved, sub-delims, ':' and '@', and '%' of a percent-encoding: what a path segment may hold.
bool isPathChar(unsigned char c) {
  return std::isalnum(c) || std::string_view("-._~!$&'()*+,;=:@%").find(char(c)) != std::string_view::npos;
}

}  // namespace

bool isDicomUid(std::string_view uid) {
  if (uid.empty() || uid.size() > 64 || uid.front() == '.' || uid.back() == '.') return false;
  for (size_t i = 0; i < uid.size(); ++i) {
    if (uid[i] == '.') {
      if (uid[i + 1] == '.') return false;
    } else if (uid[i] < '0' || uid[i] > '9') {
      return false;
    }
  }
  return true;
}

bool isDicomWebInput(std::string_view input) {
  const std::string head = lowerText(input.substr(0, 12));
  return head.rfind("dicomweb://", 0) == 0 || head.rfind("dicomwebs://", 0) == 0;
}

DicomWebUrl parseDicomWebUrl(const std::string& input) {
  DicomWebUrl url;
  url.input = input;
  const size_t schemeEnd = input.find("://");
  if (schemeEnd == std::string::npos || !isDicomWebInput(input)) badUrl(input, "not a dicomweb:// or dicomwebs:// URL");
  url.https = lowerText(input.substr(0, schemeEnd)) == "dicomwebs";
  std::string rest = input.substr(schemeEnd + 3);
  if (rest.find_first_of("?#") != std::string::npos)
    badUrl(input, "a query or fragment ('?', '#') has no place in the series' address");
  const size_t slash = rest.find('/');
  const std::string authority = rest.substr(0, slash);
  const std::string path = slash == std::string::npos ? "" : rest.substr(slash);
  if (authority.find('@') != std::string::npos)
    throw InputError(input +
                     ": credentials do not belong in the URL (a command line is visible to every user of the "
                     "machine): give them in a file (--auth-file FILE) or in VOXBRICK_DICOMWEB_AUTH, as 'basic "
                     "USER:PASSWORD' or 'bearer TOKEN'");
  if (authority.empty()) badUrl(input, "no host");
  std::string host, port;
  bool portGiven = false;
  if (authority.front() == '[') {
    const size_t close = authority.find(']');
    if (close == std::string::npos) badUrl(input, "an IPv6 address without its closing ']'");
    host = authority.substr(0, close + 1);
    const std::string after = authority.substr(close + 1);
    if (!after.empty() && after.front() != ':') badUrl(input, "'" + after + "' after the IPv6 address");
    portGiven = !after.empty();
    if (portGiven) port = after.substr(1);
    const std::string inside = host.substr(1, host.size() - 2);
    if (inside.empty() || !std::all_of(inside.begin(), inside.end(),
                                       [](unsigned char c) { return std::isxdigit(c) || c == ':' || c == '.'; }))
      badUrl(input, "'" + host + "' is not an IPv6 address");
  } else {
    const size_t colon = authority.find(':');
    host = authority.substr(0, colon);
    portGiven = colon != std::string::npos;
    if (portGiven) port = authority.substr(colon + 1);
    if (host.empty() || !std::all_of(host.begin(), host.end(), [](unsigned char c) { return isHostChar(c); }))
      badUrl(input, "'" + host + "' is not a host name or address");
  }
  if (portGiven) {
    if (port.empty() || port.size() > 5 ||
        !std::all_of(port.begin(), port.end(), [](char c) { return c >= '0' && c <= '9'; }) || std::stoi(port) < 1 ||
        std::stoi(port) > 65535)
      badUrl(input, "port '" + port + "' is not a number from 1 to 65535");
  }

  std::vector<std::string> segments;
  for (size_t at = 0; at < path.size();) {
    const size_t next = path.find('/', at + 1);
    std::string segment = path.substr(at + 1, next == std::string::npos ? std::string::npos : next - at - 1);
    if (segment.empty() && next != std::string::npos) badUrl(input, "an empty path segment ('//')");
    if (!segment.empty()) segments.push_back(segment);
    at = next == std::string::npos ? path.size() : next;
  }
  for (const std::string& s : segments)
    if (!std::all_of(s.begin(), s.end(), [](unsigned char c) { return isPathChar(c); }))
      badUrl(input, "path segment '" + s + "' holds characters a URL path cannot (percent-encode them)");
  // The last "studies" segment followed by a UID, then optionally "series" and a UID, ends the path.
  size_t studies = segments.size();
  for (size_t i = segments.size(); i-- > 0;)
    if (segments[i] == "studies") {
      studies = i;
      break;
    }
  if (studies == segments.size()) badUrl(input, "no /studies/ in the path");
  const size_t tail = segments.size() - studies;
  if (tail != 2 && tail != 4) badUrl(input, "the path must end at a study or a series");
  url.study = segments[studies + 1];
  if (!isDicomUid(url.study)) badUrl(input, "'" + url.study + "' is not a DICOM UID (digits and dots, at most 64)");
  if (tail == 4) {
    if (segments[studies + 2] != "series") badUrl(input, "'" + segments[studies + 2] + "' where 'series' belongs");
    url.series = segments[studies + 3];
    if (!isDicomUid(url.series)) badUrl(input, "'" + url.series + "' is not a DICOM UID (digits and dots, at most 64)");
  }
  url.base = std::string(url.https ? "https://" : "http://") + host + (port.empty() ? "" : ":" + port);
  for (size_t i = 0; i < studies; ++i) url.base += "/" + segments[i];
  return url;
}

std::string DicomWebUrl::studyUrl() const { return base + "/studies/" + study; }

std::string DicomWebUrl::seriesUrl(const std::string& seriesUid) const {
  return studyUrl() + "/series/" + (seriesUid.empty() ? series : seriesUid);
}

std::string DicomWebUrl::seriesSearchUrl() const { return studyUrl() + "/series"; }

std::string DicomWebUrl::instancesUrl(const std::string& seriesUid) const {
  return seriesUrl(seriesUid) + "/instances";
}

std::string DicomWebUrl::instanceUrl(const std::string& seriesUid, const std::string& instanceUid) const {
  return instancesUrl(seriesUid) + "/" + instanceUid;
}

}  // namespace voxbrick::store
