// A brick store and its host cache as a dataset.
#include "render/volume/BrickStoreDataset.h"

#include <nlohmann/json.hpp>

#include "brickstore/read/OpenAnyStore.h"

namespace voxbrick::render {

BrickStoreDataset::BrickStoreDataset(std::string name, const std::filesystem::path& path, size_t cacheBytes,
                                     int decodeThreads, const store::StoreOpenOptions& options)
    : Dataset(std::move(name), path),
      mStore(store::openAnyStore(path, options)),
      mCache(std::make_shared<store::BrickCache>(mStore, cacheBytes, decodeThreads)) {}

std::string BrickStoreDataset::infoJson() const {
  nlohmann::json j = nlohmann::json::parse(mStore->meta().toJson());
  j["kind"] = std::string(kind());
  const store::Orientation& o = mStore->meta().orientation;
  j["orientation"] = {{"space", "RAS"}, {"axes", o.axes}, {"origin", o.origin}, {"patient", o.patient}};
  return j.dump();
}

WorldFrame BrickStoreDataset::worldFrame() const {
  const store::StoreMeta& m = mStore->meta();
  return WorldFrame::of(m.orientation, m.dims, m.spacing);
}

}  // namespace voxbrick::render
