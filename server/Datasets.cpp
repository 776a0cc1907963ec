// Dataset discovery and lazy opening.
#include "server/Datasets.h"

#include <algorithm>

namespace voxbrick::server {

bool DatasetRegistry::validName(const std::string& name) {
  if (name.empty() || name.size() > 255 || name == "." || name == "..") return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_' ||
           c == '.';
  });
}

DatasetRegistry::DatasetRegistry(std::filesystem::path directory, size_t cacheBytes)
    : mDirectory(std::move(directory)), mCacheBytes(cacheBytes) {}

std::vector<std::string> DatasetRegistry::names() const {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(mDirectory, ec)) {
    const std::string name = entry.path().filename().string();
    if (validName(name) && render::isDataset(entry.path())) out.push_back(name);
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::shared_ptr<const render::Dataset> DatasetRegistry::open(const std::string& name) {
  std::lock_guard lock(mMutex);
  if (auto it = mOpen.find(name); it != mOpen.end()) return it->second;
  // The name is checked before it touches a path: "..", "/etc" and the like must never reach the file system.
  if (!validName(name) || !render::isDataset(mDirectory / name))
    throw DatasetNotFound("no dataset '" + name + "' (see ListDatasets)");
  // One host budget for the server: the datasets open share it equally, so one more shrinks the others' caches.
  const size_t share = mCacheBytes / (mOpen.size() + 1);
  auto dataset = render::openDataset(name, mDirectory / name, share);
  for (const auto& [other, open] : mOpen) open->setCacheBudget(share);
  mOpen[name] = dataset;
  return dataset;
}

std::vector<std::shared_ptr<const render::Dataset>> DatasetRegistry::opened() const {
  std::lock_guard lock(mMutex);
  std::vector<std::shared_ptr<const render::Dataset>> out;
  for (const auto& [name, dataset] : mOpen) out.push_back(dataset);
  return out;
}

}  // namespace voxbrick::server
