// Reading one float grid of a .vdb file, as prep ingests it and as a live store serves it: the same grid, box,
// spacing and description for both. Internal to brickstore/ (it includes OpenVDB).
#pragma once

#include <optional>
#include <string>

#include <openvdb/openvdb.h>

#include "brickstore/format/Types.h"

namespace voxbrick::store {

/// A float grid chosen from a .vdb file and the volume it stands for.
struct VdbFloatGrid {
  openvdb::FloatGrid::Ptr grid;
  openvdb::CoordBBox bbox;  ///< the volume: the active voxels' bounding box; voxel (0, 0, 0) is bbox.min()
  Vec3i dims;               ///< bbox.dim()
  Vec3d spacing;            ///< from the grid's transform, or the spacing given
  std::string description;  ///< "OpenVDB grid 'NAME' NXxNYxNZ (FILE)", what prep records as the source
};

/// Reads `path` whole (checking every read, so a truncated file is an error) and picks the grid named `gridName`,
/// else (empty) the first float grid. Throws InputError naming the file and the problem: unreadable or malformed
/// file, no such grid, a grid that is not float, a transform that is not linear and uniform (unless `spacing` is
/// given, which then replaces the grid's), no active voxels.
VdbFloatGrid readVdbFloatGrid(const std::string& path, const std::string& gridName,
                              const std::optional<Vec3d>& spacing = std::nullopt);

}  // namespace voxbrick::store
