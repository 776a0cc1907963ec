// QIDO-RS over every series of a service, in pages.
#include "brickstore/ingest/dicomweb/SeriesSearch.h"

#include <set>

#include "brickstore/format/Errors.h"
#include "brickstore/source/DicomClasses.h"

namespace voxbrick::store {
namespace {

constexpr size_t kMaxBytes = size_t(64) << 20;

/// The pages' bodies together, within kMaxBytes.
class Pages final : public ResponseHandler {
 public:
  explicit Pages(size_t& total) : mTotal(total) {}
  void begin(const std::string&) override { mText.clear(); }
  void data(const char* bytes, size_t size) override {
    if (mTotal + mText.size() + size > kMaxBytes)
      throw InputError("QIDO-RS series search: the answers exceed " + std::to_string(kMaxBytes >> 20) + " MB");
    mText.append(bytes, size);
  }
  void end() override { mTotal += mText.size(); }
  const std::string& text() const { return mText; }

 private:
  size_t& mTotal;
  std::string mText;
};

}  // namespace

std::vector<QidoSeries> searchAllSeries(const std::string& root, const HttpOptions& options, size_t pageSize) {
  std::string base = root;
  while (!base.empty() && base.back() == '/') base.pop_back();
  // The attributes a listing shows besides the default ones (PS3.18 10.6.3.3.2: a server may return more).
  const std::string fields =
      "&includefield=0020000D&includefield=00081030&includefield=00080020&includefield=00201209"
      "&includefield=0008103E&includefield=00100010&includefield=00100020&includefield=00100030";
  HttpClient client(options);
  std::vector<QidoSeries> all;
  std::set<std::string> seen;
  size_t total = 0;
  for (size_t offset = 0;;) {
    const std::string url = base + "/series?limit=" + std::to_string(pageSize) + "&offset=" +
                            std::to_string(offset) + fields;
    Pages page(total);
    client.get(url, "application/dicom+json", page);
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

std::vector<QidoSeries> searchImageSeries(const std::string& root, const HttpOptions& options) {
  std::string base = root;
  while (!base.empty() && base.back() == '/') base.pop_back();
  std::vector<QidoSeries> images;
  HttpClient client(options);
  for (QidoSeries& s : searchAllSeries(base, options)) {
    if (!isNonImageModality(s.modality)) {
      images.push_back(std::move(s));
      continue;
    }
    if (s.studyUid.empty()) continue;  // its instances cannot be searched
    const std::string search = base + "/studies/" + s.studyUid + "/series/" + s.seriesUid + "/instances";
    QidoInstancePages pages(search, s.seriesUid, kMaxBytes);
    for (bool more = true; more;) {
      const std::string url = pages.nextUrl() + "&includefield=00080016";
      size_t total = 0;
      Pages page(total);
      client.get(url, "application/dicom+json", page);
      more = pages.add(page.text(), client.warning());
    }
    bool listedClasses = false, image = false;
    for (const QidoInstance& i : pages.instances()) {
      listedClasses = listedClasses || !i.sopClassUid.empty();
      image = image || (!i.sopClassUid.empty() && dicomNonImageKind(i.sopClassUid).empty());
    }
    if (image) {
      s.modality.clear();
      images.push_back(std::move(s));
    }
  }
  return images;
}

}  // namespace voxbrick::store
