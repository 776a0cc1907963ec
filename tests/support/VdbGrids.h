// Small OpenVDB files for the tests of a .vdb read live: a sparse grid and a dense one, made with OpenVDB itself.
#pragma once

#include <cmath>
#include <filesystem>
#include <limits>

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>

namespace voxbrick::test {

/// A sparse float grid (background 0.25, voxel size 0.5): a ball of smooth values around (-20, -10, 5) with one NaN
/// voxel, a slab of varying values near (43, 31, 61), a lone voxel at (70, 50, 70), an active 8^3 tile (a tile, so
/// no leaf holds it), an inactive voxel holding 1.5 and an active voxel holding the background. Most bricks of its
/// 97x67x72 box hold only the background; its origin is at negative coordinates.
inline openvdb::FloatGrid::Ptr sparseGrid(const std::string& name = "density") {
  openvdb::initialize();
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.25f);
  grid->setName(name);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(0.5));
  openvdb::FloatGrid::Accessor acc = grid->getAccessor();
  for (int z = -1; z <= 11; ++z)
    for (int y = -16; y <= -4; ++y)
      for (int x = -26; x <= -14; ++x) {
        const double r = std::sqrt(double((x + 20) * (x + 20) + (y + 10) * (y + 10) + (z - 5) * (z - 5)));
        if (r <= 6) acc.setValue(openvdb::Coord(x, y, z), float(1.0 + 2.0 * std::cos(r / 4.0) + 0.01 * x));
      }
  acc.setValue(openvdb::Coord(-20, -10, 6), std::numeric_limits<float>::quiet_NaN());
  for (int z = 60; z <= 62; ++z)
    for (int y = 30; y <= 33; ++y)
      for (int x = 40; x <= 47; ++x)
        acc.setValue(openvdb::Coord(x, y, z), float(0.5 + 0.1 * (x - 40) + 0.2 * (z - 60)));
  acc.setValue(openvdb::Coord(70, 50, 70), 3.0f);
  grid->tree().fill(openvdb::CoordBBox(openvdb::Coord(16, 0, 32), openvdb::Coord(23, 7, 39)), 2.0f, true);
  acc.setValueOff(openvdb::Coord(0, 40, 20), 1.5f);
  acc.setValueOn(openvdb::Coord(10, 10, 10), 0.25f);
  return grid;
}

/// A dense float grid (background 0, voxel size 1): every voxel of the 70x45x38 box from (5, -3, 11) holds a smooth
/// value in about [0.1, 1], none the background.
inline openvdb::FloatGrid::Ptr denseGrid(const std::string& name = "density") {
  openvdb::initialize();
  const openvdb::CoordBBox box(openvdb::Coord(5, -3, 11), openvdb::Coord(74, 41, 48));
  openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ> dense(box);
  for (int z = box.min().z(); z <= box.max().z(); ++z)
    for (int y = box.min().y(); y <= box.max().y(); ++y)
      for (int x = box.min().x(); x <= box.max().x(); ++x)
        dense.setValue(openvdb::Coord(x, y, z),
                       float(0.55 + 0.35 * std::sin(0.21 * x) * std::cos(0.17 * y) + 0.1 * std::sin(0.3 * z)));
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
  grid->setName(name);
  openvdb::tools::copyFromDense(dense, *grid, 0.0f);
  return grid;
}

/// Writes `grids` to `path` as one .vdb file.
inline void writeVdb(const std::filesystem::path& path, const openvdb::GridPtrVec& grids) {
  openvdb::io::File file(path.string());
  file.write(grids);
  file.close();
}

}  // namespace voxbrick::test
