// Opening a dataset by path, whatever its kind: each kind's driver (DatasetDriver.h) recognises and opens its own.
// GL-free.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "brickstore/read/BrickStore.h"
#include "render/core/Dataset.h"
#include "render/engine/DatasetDriver.h"

namespace voxbrick::render {

/// Whether `path` holds a dataset of a kind this build can open: a directory with a store.json, a file whose name
/// ends in .vdb (read live), an OME-Zarr directory, or a mesh store (mesh/MeshStore.h), or a kind registered at run
/// time.
bool isDataset(const std::filesystem::path& path);

/// The files whose change on disk means the dataset at `path` was replaced (a brick store's store.json and
/// bricks.bin, a mesh store's mesh.json, mesh-index.bin and mesh-data.bin, an OME-Zarr's metadata, or the .vdb file
/// itself).
std::vector<std::filesystem::path> datasetFiles(const std::filesystem::path& path);

/// Opens the dataset at `path` under `name` with the driver of the kind that recognises it (`options` apply to a
/// .vdb: grid name and brick size, and to an OME-Zarr: time point and channel). `cacheBytes` is the host memory it
/// may use: a brick store's cache; a mesh is read whole when it fits (TetMeshData::hostBytes), and otherwise paged
/// by view (TetMeshSource: its points resident, each frame's chunks within the rest), refused with RenderLimitError
/// when even its points exceed it. Throws std::runtime_error naming the path when it is no dataset, and the kind's
/// own errors (mesh::MeshError for a corrupt mesh store) when it cannot be opened.
std::shared_ptr<const Dataset> openDataset(std::string name, const std::filesystem::path& path, size_t cacheBytes,
                                           const store::StoreOpenOptions& options = {});

/// `voxbrick info` of the dataset at `path` (DatasetDriver::describe of the kind that recognises it; a path none
/// recognises is described as a brick store, whose errors name what a store directory lacks).
DatasetReport describeDataset(const std::filesystem::path& path, const store::StoreOpenOptions& options = {});

}  // namespace voxbrick::render
