// Reading one float grid of a .vdb file: every read checked, the grid chosen by name or as the first float grid.
#include "brickstore/vdb/VdbGrid.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <openvdb/io/Stream.h>

#include "brickstore/format/Errors.h"
#include "brickstore/vdb/OpenVdbInit.h"
#include "brickstore/vdb/VdbHeader.h"

namespace voxbrick::store {
namespace {

/// The library's message, kept to one short printable line: a corrupt file can put arbitrary bytes into it.
std::string printable(const char* what) {
  std::string out;
  for (const char* c = what; *c && out.size() < 160; ++c) out += (*c >= 0x20 && *c < 0x7f) ? *c : '?';
  return out;
}

/// Every grid of the file, in file order, after a bounds check of its header. io::File does not check its reads, so a
/// file cut inside its last grid loads without complaint; reading it as an io::Stream over an ifstream that throws on a
/// short read catches every truncation, at the price of loading all grids (VDB files rarely hold more than a few).
openvdb::GridPtrVec readAllGrids(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(errnoMessage(path));
  checkVdbHeader(path);  // before OpenVDB sizes anything from the header's lengths and counts
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
    throw InputError(path + ": grid '" + chosen->getName() + "' is " + chosen->valueType() + ", expected a float grid");
  return openvdb::gridPtrCast<openvdb::FloatGrid>(chosen);
}

}  // namespace

/// The voxel spacing of an axis-aligned linear transform, one per axis: uniform, or anisotropic as prep writes for
/// volumes with non-uniform spacing (a scale and a translation). Rotated, sheared or non-linear transforms are
/// refused: a store's voxels lie along its axes.
Vec3d axisAlignedSpacing(const openvdb::FloatGrid& grid, const std::string& path) {
  const openvdb::math::Transform& xform = grid.transform();
  const std::string what = path + ": grid '" + grid.getName() + "' has a ";
  if (!xform.isLinear())
    throw InputError(what + "non-linear transform (" + xform.mapType() + "); give the spacing explicitly");
  const openvdb::math::Mat4d m = xform.baseMap()->getAffineMap()->getMat4();
  const double largest = std::max({std::abs(m(0, 0)), std::abs(m(1, 1)), std::abs(m(2, 2))});
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (i != j && !(std::abs(m(i, j)) <= 1e-9 * largest))
        throw InputError(what + "rotated or sheared transform (" + xform.mapType() + "); give the spacing explicitly");
  for (int a = 0; a < 3; ++a)
    if (!(std::abs(m(a, a)) > 0) || !std::isfinite(m(a, a)))
      throw InputError(what + "voxel size " + std::to_string(m(a, a)) + " along axis " + std::to_string(a));
  return {std::abs(m(0, 0)), std::abs(m(1, 1)), std::abs(m(2, 2))};
}

VdbFloatGrid readVdbFloatGrid(const std::string& path, const std::string& gridName,
                              const std::optional<Vec3d>& givenSpacing) {
  initializeOpenVdb();
  openvdb::FloatGrid::Ptr grid = chooseFloatGrid(readAllGrids(path), path, gridName);

  Vec3d spacing;
  if (givenSpacing) {
    spacing = *givenSpacing;
    for (int a = 0; a < 3; ++a)
      if (!(spacing[a] > 0) || !std::isfinite(spacing[a]))
        throw InputError(path + ": the given spacing must be positive and finite");
  } else {
    spacing = axisAlignedSpacing(*grid, path);
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
