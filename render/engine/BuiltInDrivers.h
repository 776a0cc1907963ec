// The drivers of the kinds built in (GridDriver.cpp, MeshDriver.cpp), registered by Drivers.cpp. GL-free.
#pragma once

#include <memory>

#include "render/engine/DatasetDriver.h"

namespace voxbrick::render {

/// Brick stores: a prepped store directory, a .vdb or an OME-Zarr directory read live (BrickStoreDataset).
std::shared_ptr<const DatasetDriver> gridDriver();
/// Tetrahedral mesh stores (TetMeshDataset).
std::shared_ptr<const DatasetDriver> meshDriver();

}  // namespace voxbrick::render
