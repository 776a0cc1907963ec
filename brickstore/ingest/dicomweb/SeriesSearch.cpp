// QIDO-RS over every series of a service, in pages.
#include "brickstore/ingest/dicomweb/SeriesSearch.h"

#include <algorithm>
#include <set>

#include "brickstore/format/Errors.h"
#include "brickstore/source/DicomClasses.h"

namespace voxbrick::store {
void QidoBody::begin(const std::string& contentType) {
  mText.clear();
  mContentType = contentType;
}

void QidoBody::data(const char* bytes, size_t size) {
  if (mText.size() + size > mLimit)
    throw InputError(mWhat + ": the answer exceeds " + std::to_string(mLimit >> 20) + " MB");
  mText.append(bytes, size);
}

void QidoBody::end() {
  const std::string media = mContentType.substr(0, mContentType.find(';'));
  if (!mText.empty() && media.find("json") == std::string::npos)
    throw InputError(mWhat + ": the answer is '" + media.substr(0, 60) +
                     "', not application/dicom+json (is the URL the DICOMweb root, or a proxy's sign-in page?)");
}

std::vector<QidoInstance> searchInstances(HttpClient& client, const std::string& instancesUrl,
                                          const std::string& seriesUid) {
  QidoInstancePages pages(instancesUrl, seriesUid, kMaxQidoBytes);
  for (bool more = true; more;) {
    const std::string search = pages.nextUrl();
    QidoBody body("GET " + search, pages.bytesLeft());
    client.get(search, "application/dicom+json", body);
    more = pages.add(body.text(), client.warning());
  }
  return pages.instances();
}

namespace {

/// `root` without a trailing slash.
std::string withoutTrailingSlash(std::string root) {
  while (!root.empty() && root.back() == '/') root.pop_back();
  return root;
}

/// searchAllSeries over `client`, of the root `base` (no trailing slash).
std::vector<QidoSeries> allSeries(HttpClient& client, const std::string& base, size_t pageSize) {
  // The attributes a listing shows besides the default ones (PS3.18 10.6.3.3.2: a server may return more).
  const std::string fields =
      "&includefield=0020000D&includefield=00081030&includefield=00080020&includefield=00201209"
      "&includefield=0008103E&includefield=00100010&includefield=00100020&includefield=00100030";
  std::vector<QidoSeries> all;
  std::set<std::string> seen;
  size_t total = 0;
  for (size_t offset = 0;;) {
    const std::string url = base + "/series?limit=" + std::to_string(pageSize) + "&offset=" +
                            std::to_string(offset) + fields;
    QidoBody page("GET " + url, kMaxQidoBytes - total);
    client.get(url, "application/dicom+json", page);
    total += page.text().size();
    const std::vector<QidoSeries> got = parseQidoSeries(page.text(), "GET " + url);
    size_t added = 0;
    for (const QidoSeries& s : got)
      if (seen.insert(s.seriesUid).second) {
        all.push_back(s);
        ++added;
      }
    // The last page brings fewer than asked, unless the server cut it short (Warning 299); more than asked is
    // everything at once.
    if ((got.size() < pageSize && !(got.size() > 0 && qidoResultsCut(client.warning()))) || got.size() > pageSize)
      return all;
    if (added == 0)
      throw InputError("GET " + url + ": a page of series already listed: the server ignores 'offset', so its "
                       "series cannot be listed page by page");
    offset += got.size();
  }
}

}  // namespace

std::vector<QidoSeries> searchAllSeries(const std::string& root, const HttpOptions& options, size_t pageSize) {
  HttpClient client(options);
  return allSeries(client, withoutTrailingSlash(root), pageSize);
}

std::vector<QidoSeries> searchImageSeries(const std::string& root, const HttpOptions& options) {
  const std::string base = withoutTrailingSlash(root);
  std::vector<QidoSeries> images;
  HttpClient client(options);  // one connection for the listing and the instance searches
  for (QidoSeries& s : allSeries(client, base, kQidoPageSize)) {
    if (!isNonImageModality(s.modality)) {
      images.push_back(std::move(s));
      continue;
    }
    if (s.studyUid.empty()) continue;  // its instances cannot be searched
    const std::vector<QidoInstance> instances =
        searchInstances(client, base + "/studies/" + s.studyUid + "/series/" + s.seriesUid + "/instances", s.seriesUid);
    const bool image = std::any_of(instances.begin(), instances.end(), [](const QidoInstance& i) {
      return !i.sopClassUid.empty() && dicomNonImageKind(i.sopClassUid).empty();
    });
    if (image) {
      s.modality.clear();
      images.push_back(std::move(s));
    }
  }
  return images;
}

}  // namespace voxbrick::store
