// Dataset discovery and lazy opening.
#include "server/Datasets.h"

#include "common/Names.h"
#include "render/engine/Datasets.h"
#include "server/PacsCatalog.h"

#include <algorithm>

#include <sys/stat.h>

namespace voxbrick::server {

bool DatasetRegistry::validName(const std::string& name) {
  // Hidden entries are never datasets: an upload's scratch (.upload-*) among them.
  if (name.empty() || name.size() > 255 || name.front() == '.') return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_' ||
           c == '.';
  });
}

DatasetRegistry::DatasetRegistry(std::filesystem::path directory, size_t cacheBytes,
                                 std::function<void(const std::string&)> check)
    : mDirectory(std::move(directory)), mCacheBytes(cacheBytes), mCheck(std::move(check)) {}

std::vector<std::string> DatasetRegistry::names(const Visible& visible) const {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(mDirectory, ec)) {
    const std::string name = entry.path().filename().string();
    if (validName(name) && (!visible || visible(name)) && render::isDataset(entry.path())) out.push_back(name);
  }
  if (mPacs)
    for (const std::string& name : mPacs->names())
      if (!visible || visible(name)) out.push_back(name);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::string datasetIdentity(const std::filesystem::path& path) {
  std::string out;
  for (const std::filesystem::path& file : render::datasetFiles(path)) {
    struct stat s {};
    if (::stat(file.c_str(), &s) != 0) return {};
    out += std::to_string(s.st_dev) + ":" + std::to_string(s.st_ino) + ":" + std::to_string(s.st_size) + ":" +
           std::to_string(s.st_mtim.tv_sec) + "." + std::to_string(s.st_mtim.tv_nsec) + ";";
  }
  return out;
}

std::shared_ptr<const render::Dataset> DatasetRegistry::open(const std::string& name, const Visible& visible) {
  std::lock_guard lock(mMutex);
  // The name is checked before it touches a path: "..", "/etc" and the like must never reach the file system. A
  // dataset the session may not see is refused before its files are looked at, in the words of a missing one.
  if (!validName(name) || (visible && !visible(name)))
    throw DatasetNotFound(common::unknownName("dataset", name, names(visible)));
  // A PACS series is opened from the PACS cache, once prepped there (until then: Busy with its progress).
  std::filesystem::path path = mDirectory / name;
  if (mPacs && mPacs->owns(name)) {
    try {
      path = mPacs->resolve(name);
    } catch (const std::out_of_range& e) {
      throw DatasetNotFound(common::unknownName("dataset", name, names(visible)) + " (" + e.what() + ")");
    }
  }
  const std::string identity = datasetIdentity(path);
  if (auto it = mOpen.find(name); it != mOpen.end()) {
    if (it->second.identity == identity) return it->second.dataset;
    mOpen.erase(it);  // replaced on disk (or gone): sessions holding the old one keep it until they open again
  }
  if (!render::isDataset(path)) throw DatasetNotFound(common::unknownName("dataset", name, names(visible)));
  // One host budget for the server: the datasets open share it equally, so one more shrinks the others' caches.
  const size_t share = mCacheBytes / (mOpen.size() + 1);
  auto dataset = render::openDataset(name, path, share);
  if (mCheck) {
    try {
      mCheck(name);
    } catch (const std::exception& e) {
      throw DatasetUnavailable(e.what());
    }
  }
  for (const auto& [other, open] : mOpen) open.dataset->setCacheBudget(share);
  mOpen[name] = {dataset, identity};
  return dataset;
}

std::vector<std::shared_ptr<const render::Dataset>> DatasetRegistry::opened() const {
  std::lock_guard lock(mMutex);
  std::vector<std::shared_ptr<const render::Dataset>> out;
  for (const auto& [name, open] : mOpen) out.push_back(open.dataset);
  return out;
}

}  // namespace voxbrick::server
