// Reading one float grid of a .vdb file: every read checked, the grid chosen by name or as the first float grid.
#include "brickstore/VdbGrid.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <openvdb/io/Stream.h>

#include "brickstore/Errors.h"
#include "brickstore/OpenVdbInit.h"

namespace voxbrick::store {
namespace {

/// The library's message, kept to one short printable line: a corrupt file can put arbitrary bytes into it.
std::string printable(const char* what) {
  std::string out;
  for (const char* c = what; *c && out.size() < 160; ++c) out += (*c >= 0x20 && *c < 0x7f) ? *c : '?';
  return out;
}

/// Every grid of the file, in file order. io::File does not check its reads, so a file cut inside its last
/// grid loads without complaint; reading it as an io::Stream over an ifstream that throws on a short read
/// catches every truncation, at the price of loading all grids (VDB files rarely hold more than a few).
openvdb::GridPtrVec readAllGrids(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(errnoMessage(path));
  in.exceptions(std::ios::failbit | std::ios::badbit);
  try {
    openvdb::io::Stream stream(in, /*delayLoad=*/false);
    openvdb::GridPtrVecPtr grids = stream.getGrids();
    return grids ? *grids : openvdb::GridPtrVec{};
  } catch (const std::ios_base::failure&) {
    throw InputError(path + ": not a readable OpenVDB file (it ends early: truncated?)");
  } catch (const std::exception& e) {
    // openvdb::Exception derives from std::exception; its what() already names the kind (IoError, ...).
    throw InputError(path + ": not a readable OpenVDB file (" + printable(e.what()) + ")");
  }
}

std::string quotedList(const openvdb::GridPtrVec& grids) {
  std::string out;
  for (const openvdb::GridBase::Ptr& grid : grids)
    out += (out.empty() ? "'" : ", '") + grid->getName() + "' (" + grid->valueType() + ")";
  return out;
}

/// The grid to ingest: the one named `gridName`, else the first float grid. Throws InputError for a missing or
/// non-float grid.
openvdb::FloatGrid::Ptr chooseFloatGrid(const openvdb::GridPtrVec& grids, const std::string& path,
                                        const std::string& gridName) {
  if (grids.empty()) throw InputError(path + ": contains no grids");
  openvdb::GridBase::Ptr chosen;
  for (const openvdb::GridBase::Ptr& grid : grids) {
    if (gridName.empty() ? grid->isType<openvdb::FloatGrid>() : grid->getName() == gridName) {
      chosen = grid;
      break;
    }
  }
  if (!chosen && gridName.empty()) throw InputError(path + ": has no float grid (grids: " + quotedList(grids) + ")");
  if (!chosen) throw InputError(path + ": has no grid named '" + gridName + "' (grids: " + quotedList(grids) + ")");
  if (!chosen->isType<openvdb::FloatGrid>())
    throw InputError(path + ": grid '" + chosen->getName() + "' is " + chosen->valueType() +
                     ", expected a float grid");
  return openvdb::gridPtrCast<openvdb::FloatGrid>(chosen);
}

}  // namespace

VdbFloatGrid readVdbFloatGrid(const std::string& path, const SourceOptions& options) {
  initializeOpenVdb();
  openvdb::FloatGrid::Ptr grid = chooseFloatGrid(readAllGrids(path), path, options.gridName);

  Vec3d spacing = options.spacing;
  if (options.spacingGiven) {
    for (int a = 0; a < 3; ++a)
      if (!(spacing[a] > 0) || !std::isfinite(spacing[a]))
        throw InputError(path + ": the given spacing must be positive and finite");
  } else {
    const openvdb::math::Transform& xform = grid->transform();
    const openvdb::Vec3d voxel = xform.voxelSize();
    if (!xform.isLinear() || !xform.hasUniformScale())
      throw InputError(path + ": grid '" + grid->getName() + "' has a " +
                       (xform.isLinear() ? "non-uniform" : "non-linear") + " transform (" + xform.mapType() +
                       "); give the spacing explicitly");
    if (!(voxel[0] > 0) || !std::isfinite(voxel[0]))
      throw InputError(path + ": grid '" + grid->getName() + "' has voxel size " + std::to_string(voxel[0]));
    spacing = {voxel[0], voxel[0], voxel[0]};
  }

  const openvdb::CoordBBox bbox = grid->evalActiveVoxelBoundingBox();
  if (bbox.empty()) throw InputError(path + ": grid '" + grid->getName() + "' has no active voxels");
  VdbFloatGrid out;
  const openvdb::Coord dim = bbox.dim();
  out.dims = {dim.x(), dim.y(), dim.z()};
  out.bbox = bbox;
  out.spacing = spacing;
  out.description = "OpenVDB grid '" + grid->getName() + "' " + std::to_string(dim.x()) + "x" +
                    std::to_string(dim.y()) + "x" + std::to_string(dim.z()) + " (" +
                    std::filesystem::path(path).filename().string() + ")";
  out.grid = std::move(grid);
  return out;
}

}  // namespace voxbrick::store
