// The drivers of the kinds built in (GridDriver.cpp, MeshDriver.cpp), registered by Drivers.cpp. GL-free.
#pragma once

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "render/engine/DatasetDriver.h"

namespace voxbrick::render {

/// Brick stores: a prepped store directory, a .vdb or an OME-Zarr directory read live (BrickStoreDataset).
std::shared_ptr<const DatasetDriver> gridDriver();
/// Tetrahedral mesh stores (TetMeshDataset).
std::shared_ptr<const DatasetDriver> meshDriver();

/// `voxbrick info` of a brick store (GridInfo.cpp).
DatasetReport describeGrid(const std::filesystem::path& path, const store::StoreOpenOptions& options);

/// printf into a string, for the drivers' summary lines.
template <typename... Values>
std::string printed(const char* pattern, Values... values) {
  const int n = std::snprintf(nullptr, 0, pattern, values...);
  std::string out(size_t(std::max(n, 0)), '\0');
  std::snprintf(out.data(), out.size() + 1, pattern, values...);
  return out;
}

}  // namespace voxbrick::render
