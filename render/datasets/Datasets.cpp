// Opening a dataset by path, whatever its kind.
#include "render/datasets/Datasets.h"

#include <stdexcept>

#include "brickstore/ZarrMeta.h"
#include "mesh/MeshStore.h"
#include "render/tets/TetMeshDataset.h"
#include "render/volume/BrickStoreDataset.h"

namespace voxbrick::render {

bool isDataset(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path / "store.json", ec) || store::BrickStore::isVdbFile(path) ||
         store::isZarrDirectory(path) || mesh::looksLikeMeshStore(path);
}

std::vector<std::filesystem::path> datasetFiles(const std::filesystem::path& path) {
  if (mesh::looksLikeMeshStore(path))
    return {path / mesh::kMeshMetaFile, path / mesh::kMeshIndexFile, path / mesh::kMeshDataFile};
  // An OME-Zarr's identity is its metadata (a rewrite of the chunks alone is not seen; reopen it by name).
  if (store::isZarrDirectory(path)) return {path / ".zattrs", path / ".zgroup"};
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
                             "' is not a dataset (no store.json, not a .vdb file, not an OME-Zarr, not a mesh store)");
  return std::make_shared<BrickStoreDataset>(std::move(name), path, cacheBytes, 2, options);
}

}  // namespace voxbrick::render
