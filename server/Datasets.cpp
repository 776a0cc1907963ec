// Dataset discovery and lazy opening.
#include "server/Datasets.h"

#include <algorithm>

namespace voxbrick::server {
namespace {

bool validName(const std::string& name) {
  if (name.empty() || name.size() > 255 || name == "." || name == "..") return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_' ||
           c == '.';
  });
}

}  // namespace

DatasetRegistry::DatasetRegistry(std::filesystem::path directory, size_t cacheBytesPerDataset)
    : mDirectory(std::move(directory)), mCacheBytes(cacheBytesPerDataset) {}

std::vector<std::string> DatasetRegistry::names() const {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(mDirectory, ec)) {
    const std::string name = entry.path().filename().string();
    if (validName(name) && std::filesystem::is_regular_file(entry.path() / "store.json", ec)) out.push_back(name);
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::shared_ptr<const Dataset> DatasetRegistry::open(const std::string& name) {
  std::lock_guard lock(mMutex);
  if (auto it = mOpen.find(name); it != mOpen.end()) return it->second;
  std::error_code ec;
  const std::filesystem::path path = mDirectory / name;
  if (!validName(name) || !std::filesystem::is_regular_file(path / "store.json", ec))
    throw DatasetNotFound("no dataset '" + name + "' (see ListDatasets)");
  auto dataset = std::make_shared<Dataset>();
  dataset->name = name;
  dataset->path = path;
  auto opened = std::make_shared<render::BrickStoreDataset>(name, path, mCacheBytes);
  dataset->store = opened->store();
  dataset->cache = opened->cache();
  dataset->dataset = opened;
  mOpen[name] = dataset;
  return dataset;
}

std::vector<std::shared_ptr<const Dataset>> DatasetRegistry::opened() const {
  std::lock_guard lock(mMutex);
  std::vector<std::shared_ptr<const Dataset>> out;
  for (const auto& [name, d] : mOpen) out.push_back(d);
  return out;
}

}  // namespace voxbrick::server
