// Reading one float grid of a .vdb file, as prep ingests it and as a live store serves it: the same grid, box,
// spacing and description for both. Internal to brickstore/ (it includes OpenVDB).
#pragma once

#include <string>

#include <openvdb/openvdb.h>

#include "brickstore/VolumeSource.h"

namespace voxbrick::store {

/// A float grid chosen from a .vdb file and the volume it stands for.
struct VdbFloatGrid {
  openvdb::FloatGrid::Ptr grid;
  openvdb::CoordBBox bbox;  ///< the volume: the active voxels' bounding box; voxel (0, 0, 0) is bbox.min()
  Vec3i dims;               ///< bbox.dim()
  Vec3d spacing;            ///< from the grid's transform, or options.spacing when given
  std::string description;  ///< "OpenVDB grid 'NAME' NXxNYxNZ (FILE)", what prep records as the source
};

/// Reads `path` whole (checking every read, so a truncated file is an error) and picks the grid named
/// options.gridName, else the first float grid. Throws InputError naming the file and the problem: unreadable or
/// malformed file, no such grid, a grid that is not float, a transform that is not linear and uniform (unless
/// options.spacingGiven), no active voxels.
VdbFloatGrid readVdbFloatGrid(const std::string& path, const SourceOptions& options);

}  // namespace voxbrick::store
