// Dataset kinds and opening by path.
#include "render/Dataset.h"

#include <stdexcept>

#include <nlohmann/json.hpp>

#include "mesh/MeshStore.h"
#include "render/RenderErrors.h"
#include "render/TetDataset.h"

namespace voxbrick::render {

const char* datasetKindName(DatasetKind kind) {
  switch (kind) {
    case DatasetKind::BrickStore: return "brick-store";
    case DatasetKind::TetMesh: return "tet-mesh";
  }
  return "unknown";
}

std::optional<QualityTable> Dataset::qualityTable() const {
  const std::filesystem::path file = QualityTable::pathFor(mPath);
  std::error_code error;
  const auto time = std::filesystem::last_write_time(file, error);
  std::lock_guard lock(mQualityMutex);
  if (error) {
    mQuality.reset();
    return std::nullopt;
  }
  if (!mQuality || time != mQualityTime) {
    mQuality = QualityTable::load(mPath);
    mQualityTime = time;
  }
  return mQuality;
}

Scene resolveQuality(const Dataset& dataset, const Scene& scene, std::optional<QualityChoice>* choice) {
  if (choice) choice->reset();
  if (!scene.quality) return scene;
  const std::optional<QualityTable> table = dataset.qualityTable();
  if (!table)
    throw RenderInputError("quality " + scene.quality->text() + ": dataset '" + dataset.name() +
                           "' has no quality table (" + QualityTable::pathFor(dataset.path()).string() +
                           "); measure one with `voxbrick bench --calibrate " + dataset.path().string() + "`");
  const QualityChoice chosen = table->choose(*scene.quality, scene);
  Scene resolved = scene;
  chosen.setting.applyTo(resolved);
  resolved.validate();
  if (choice) *choice = chosen;
  return resolved;
}

BrickStoreDataset::BrickStoreDataset(std::string name, const std::filesystem::path& path, size_t cacheBytes,
                                     int decodeThreads, const store::StoreOpenOptions& options)
    : Dataset(std::move(name), path),
      mStore(store::BrickStore::openAny(path, options)),
      mCache(std::make_shared<store::BrickCache>(mStore, cacheBytes, decodeThreads)) {}

std::string BrickStoreDataset::infoJson() const {
  nlohmann::json j = nlohmann::json::parse(mStore->meta().toJson());
  j["kind"] = datasetKindName(kind());
  const store::Orientation& o = mStore->meta().orientation;
  j["orientation"] = {{"space", "RAS"}, {"axes", o.axes}, {"origin", o.origin}, {"patient", o.patient}};
  return j.dump();
}

WorldFrame BrickStoreDataset::worldFrame() const {
  const store::StoreMeta& m = mStore->meta();
  return WorldFrame::of(m.orientation, m.dims, m.spacing);
}

bool isDataset(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path / "store.json", ec) || store::BrickStore::isVdbFile(path) ||
         mesh::looksLikeMeshStore(path);
}


std::vector<std::filesystem::path> datasetFiles(const std::filesystem::path& path) {
  if (mesh::looksLikeMeshStore(path))
    return {path / mesh::kMeshMetaFile, path / mesh::kMeshIndexFile, path / mesh::kMeshDataFile};
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return {path / "store.json", path / "bricks.bin"};
  return {path};
}

std::shared_ptr<const Dataset> openDataset(std::string name, const std::filesystem::path& path, size_t cacheBytes,
                                           const store::StoreOpenOptions& options) {
  if (mesh::looksLikeMeshStore(path)) {
    // A mesh that fits the host budget whole is read and checked once, here; a larger one is paged by view: its
    // points stay in memory, and each frame reads the chunks it needs (TetMeshSource).
    auto meshStore = std::make_shared<const mesh::MeshStore>(mesh::MeshStore::open(path));
    const mesh::MeshStoreInfo& info = meshStore->info();
    std::shared_ptr<const TetMeshSource> source;
    if (TetMeshData::hostBytes(info.tetCount, info.vertexCount, info.boundaryFaceCount) <= cacheBytes)
      source = std::make_shared<const TetMeshSource>(
          std::make_shared<const TetMeshData>(meshStore->readAll(), meshStore->readTopology()));
    else
      source = std::make_shared<const TetMeshSource>(std::move(meshStore), cacheBytes);
    return std::make_shared<TetMeshDataset>(std::move(name), path, std::move(source));
  }
  if (!isDataset(path))
    throw std::runtime_error("openDataset: '" + path.string() +
                             "' is not a dataset (no store.json, not a .vdb file, not a mesh store)");
  return std::make_shared<BrickStoreDataset>(std::move(name), path, cacheBytes, 2, options);
}

}  // namespace voxbrick::render
