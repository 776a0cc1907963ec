// Tests of the OpenVDB source against real .vdb files: voxel-exact reads, grid selection, and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include "brickstore/format/Errors.h"
#include "brickstore/ingest/Sources.h"
#include "support/TestSupport.h"

namespace voxbrick::store {
namespace {

using test::ScratchDir;

class VdbSourceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { openvdb::initialize(); }

  /// A float grid with scattered voxels, an active tile, an inactive non-background voxel, background 0.5 and
  /// voxel size 0.25.
  static openvdb::FloatGrid::Ptr makeDensity(const std::string& name) {
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.5f);
    grid->setName(name);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(0.25));
    openvdb::FloatGrid::Accessor acc = grid->getAccessor();
    for (int z = -5; z <= 2; ++z)
      for (int y = 3; y <= 11; ++y)
        for (int x = -9; x <= -2; x += 2) acc.setValue(openvdb::Coord(x, y, z), float(x * 100 + y * 10 + z));
    acc.setValue(openvdb::Coord(30, -4, 20), 7.0f);
    // An aligned 8^3 fill becomes an active tile, which has no leaf to copy from.
    grid->tree().fill(openvdb::CoordBBox(openvdb::Coord(16, 0, 8), openvdb::Coord(23, 7, 15)), 3.0f, true);
    acc.setValueOff(openvdb::Coord(0, 0, 0), -2.0f);
    return grid;
  }

  /// Writes grids to `name` in the scratch dir and returns its path.
  std::string write(const std::string& name, const openvdb::GridPtrVec& grids) {
    std::string path = (mDir / name).string();
    openvdb::io::File(path).write(grids);
    return path;
  }

  /// A file of three grids: a vec3s grid first, then "density", then a float grid "temperature".
  std::string writeStandard() {
    openvdb::Vec3SGrid::Ptr velocity = openvdb::Vec3SGrid::create();
    velocity->setName("velocity");
    velocity->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3s(1, 0, 0));
    openvdb::FloatGrid::Ptr temperature = openvdb::FloatGrid::create(-1.0f);
    temperature->setName("temperature");
    temperature->tree().setValue(openvdb::Coord(4, 5, 6), 300.0f);
    temperature->tree().setValue(openvdb::Coord(6, 5, 4), 310.0f);
    return write("grids.vdb", {velocity, makeDensity("density"), temperature});
  }

  /// The message of the InputError that opening `path` throws.
  static std::string openError(const std::string& path, const SourceOptions& options = {}) {
    try {
      openVdbSource(path, options);
    } catch (const InputError& e) {
      return e.what();
    }
    ADD_FAILURE() << path << " opened";
    return {};
  }

  /// Reads the whole source in uneven batches and compares every voxel with the grid's accessor.
  static void expectMatchesGrid(VolumeSource& source, const openvdb::FloatGrid& grid) {
    const openvdb::CoordBBox bbox = grid.evalActiveVoxelBoundingBox();
    const Vec3i n = source.info().dims;
    ASSERT_EQ(n, (Vec3i{bbox.dim().x(), bbox.dim().y(), bbox.dim().z()}));
    std::vector<float> volume(static_cast<size_t>(n.volume()), -999.0f);
    int64_t z = 0;
    for (int64_t batch : {int64_t{1}, int64_t{3}, n.z}) {
      const int64_t count = std::min(batch, n.z - z);
      source.readSlices(count, volume.data() + z * n.x * n.y);
      z += count;
    }
    ASSERT_EQ(z, n.z);
    openvdb::FloatGrid::ConstAccessor acc = grid.getConstAccessor();
    for (int64_t k = 0; k < n.z; ++k)
      for (int64_t j = 0; j < n.y; ++j)
        for (int64_t i = 0; i < n.x; ++i) {
          const openvdb::Coord xyz = bbox.min() + openvdb::Coord(int(i), int(j), int(k));
          ASSERT_EQ(volume[static_cast<size_t>((k * n.y + j) * n.x + i)], acc.getValue(xyz)) << xyz;
        }
  }

  ScratchDir mDir;
};

TEST_F(VdbSourceTest, ReadsFirstFloatGridOverActiveBoundingBox) {
  const std::string path = writeStandard();
  std::unique_ptr<VolumeSource> source = openVdbSource(path, SourceOptions{});
  const VolumeInfo& info = source->info();
  // x from -9 to 30, y from -4 to 11, z from -5 to 20.
  EXPECT_EQ(info.dims, (Vec3i{40, 16, 26}));
  EXPECT_EQ(info.spacing, (Vec3d{0.25, 0.25, 0.25}));
  EXPECT_EQ(info.type, ValueType::F32);
  EXPECT_EQ(info.background, 0.5);
  EXPECT_EQ(info.description, "OpenVDB grid 'density' 40x16x26 (grids.vdb)");
  EXPECT_EQ(source->analytic(), nullptr);

  openvdb::FloatGrid::Ptr expected = makeDensity("density");
  expectMatchesGrid(*source, *expected);
  EXPECT_THROW(source->readSlices(1, nullptr), InputError);
}

TEST_F(VdbSourceTest, StoredValuesOfInactiveVoxelsAndTilesAreKept) {
  std::unique_ptr<VolumeSource> source = openVdbSource(writeStandard(), SourceOptions{});
  const Vec3i n = source->info().dims;
  std::vector<float> volume(static_cast<size_t>(n.volume()));
  source->readSlices(n.z, volume.data());
  auto at = [&](int x, int y, int z) { return volume[static_cast<size_t>(((z + 5) * n.y + (y + 4)) * n.x + x + 9)]; };
  EXPECT_EQ(at(0, 0, 0), -2.0f);   // inactive, but not background
  EXPECT_EQ(at(20, 3, 10), 3.0f);  // inside the active tile
  EXPECT_EQ(at(-9, 3, -5), -900.0f + 30.0f - 5.0f);
  EXPECT_EQ(at(-8, 3, -5), 0.5f);  // background between the scattered voxels
  EXPECT_EQ(at(30, -4, 20), 7.0f);
}

TEST_F(VdbSourceTest, FirstFloatGridIsInFileOrder) {
  openvdb::FloatGrid::Ptr zeta = openvdb::FloatGrid::create();
  zeta->setName("zeta");
  zeta->tree().setValue(openvdb::Coord(0, 0, 0), 1.0f);
  std::unique_ptr<VolumeSource> source = openVdbSource(write("order.vdb", {zeta, makeDensity("alpha")}), {});
  EXPECT_EQ(source->info().description, "OpenVDB grid 'zeta' 1x1x1 (order.vdb)");
}

TEST_F(VdbSourceTest, SelectsGridByNameAndOverridesSpacing) {
  SourceOptions options;
  options.gridName = "temperature";
  options.spacing = {1, 2, 3};
  options.spacingGiven = true;
  std::unique_ptr<VolumeSource> source = openVdbSource(writeStandard(), options);
  EXPECT_EQ(source->info().dims, (Vec3i{3, 1, 3}));
  EXPECT_EQ(source->info().spacing, options.spacing);
  EXPECT_EQ(source->info().background, -1.0);
  std::vector<float> volume(9);
  source->readSlices(3, volume.data());
  EXPECT_EQ(volume, (std::vector<float>{-1, -1, 310, -1, -1, -1, 300, -1, -1}));
}

TEST_F(VdbSourceTest, GridSelectionErrors) {
  const std::string path = writeStandard();
  SourceOptions options;
  options.gridName = "velocity";
  std::string wrongType = openError(path, options);
  EXPECT_NE(wrongType.find(path + ": grid 'velocity' is vec3s, expected a float grid"), std::string::npos) << wrongType;

  options.gridName = "pressure";
  std::string missing = openError(path, options);
  EXPECT_NE(missing.find(path + ": has no grid named 'pressure'"), std::string::npos) << missing;
  EXPECT_NE(missing.find("'velocity' (vec3s), 'density' (float), 'temperature' (float)"), std::string::npos) << missing;

  openvdb::Vec3SGrid::Ptr only = openvdb::Vec3SGrid::create();
  only->setName("v");
  std::string noFloat = openError(write("vectors.vdb", {only}));
  EXPECT_NE(noFloat.find("has no float grid (grids: 'v' (vec3s))"), std::string::npos) << noFloat;

  std::string none = openError(write("none.vdb", {}));
  EXPECT_NE(none.find("none.vdb: contains no grids"), std::string::npos) << none;
}

TEST_F(VdbSourceTest, EmptyGridIsAnError) {
  openvdb::FloatGrid::Ptr empty = openvdb::FloatGrid::create(1.0f);
  empty->setName("density");
  empty->tree().setValueOff(openvdb::Coord(1, 1, 1), 5.0f);  // stored but inactive: still no active voxels
  std::string path = write("empty.vdb", {empty});
  EXPECT_EQ(openError(path), path + ": grid 'density' has no active voxels");
}

// An axis-aligned scale (uniform or not: prep writes anisotropic grids so) gives the spacing per axis; a rotated
// transform needs the spacing given.
TEST_F(VdbSourceTest, AxisAlignedTransformsGiveTheirSpacingRotatedOnesNeedItGiven) {
  openvdb::FloatGrid::Ptr grid = makeDensity("density");
  auto map = std::make_shared<openvdb::math::ScaleMap>(openvdb::Vec3d(1, 1, 2));
  grid->setTransform(std::make_shared<openvdb::math::Transform>(map));
  const std::string aniso = write("aniso.vdb", {grid});
  EXPECT_EQ(openVdbSource(aniso, SourceOptions{})->info().spacing, (Vec3d{1, 1, 2}));

  openvdb::math::Mat4d rotation = openvdb::math::Mat4d::identity();
  rotation.preRotate(openvdb::math::Z_AXIS, 0.3);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(rotation));
  const std::string rotated = write("rotated.vdb", {grid});
  const std::string message = openError(rotated);
  EXPECT_NE(message.find("rotated or sheared transform"), std::string::npos) << message;
  EXPECT_NE(message.find("give the spacing explicitly"), std::string::npos) << message;

  SourceOptions options;
  options.spacing = {1, 1, 2};
  options.spacingGiven = true;
  EXPECT_EQ(openVdbSource(rotated, options)->info().spacing, options.spacing);
}

TEST_F(VdbSourceTest, CorruptFilesAreInputErrors) {
  std::string garbage = (mDir / "garbage.vdb").string();
  test::writeFile(garbage, std::string("this is not a vdb file, just some bytes that look nothing like one"));
  std::string message = openError(garbage);
  EXPECT_EQ(message.rfind(garbage + ": ", 0), 0u) << message;

  std::string emptyFile = (mDir / "zero.vdb").string();
  test::writeFile(emptyFile, std::string());
  EXPECT_EQ(openError(emptyFile).rfind(emptyFile + ": ", 0), 0u);

  std::string missingFile = (mDir / "absent.vdb").string();
  EXPECT_EQ(openError(missingFile).rfind(missingFile + ": ", 0), 0u);

  // Truncated copies of a real file, cut inside the header, the metadata and every grid's data, down to the
  // last byte (which io::File alone would not notice).
  std::vector<char> bytes = test::readFile(writeStandard());
  std::vector<size_t> cuts = {16, 200, bytes.size() - 40, bytes.size() - 1};
  for (size_t part = 1; part < 24; ++part) cuts.push_back(bytes.size() * part / 24);
  for (size_t keep : cuts) {
    SCOPED_TRACE(keep);
    std::string cut = (mDir / ("cut" + std::to_string(keep) + ".vdb")).string();
    test::writeFile(cut, bytes.data(), keep);
    std::string cutMessage = openError(cut);
    EXPECT_EQ(cutMessage.rfind(cut + ": ", 0), 0u) << cutMessage;
  }
}

}  // namespace
}  // namespace voxbrick::store
