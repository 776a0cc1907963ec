// Slices into an OpenVDB tree leaf by leaf (addSlicesToTree) against tools::copyFromDense, the route it replaced: the
// same tree (compared as the bytes of its file), for slices fed in batches that start and end inside leaves, volumes
// whose sides are not multiples of 8, constant regions (tiles), background, -0 and every value type.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <openvdb/io/Stream.h>
#include <openvdb/tools/Dense.h>

#include "brickstore/VdbSlices.h"

namespace voxbrick::store {
namespace {

/// The file bytes of a grid holding `tree` (a copy), with the 36-character UUID at byte 21 blanked.
std::string fileBytes(const openvdb::FloatTree& tree) {
  auto grid = openvdb::FloatGrid::create(std::make_shared<openvdb::FloatTree>(tree));
  grid->setName("density");
  std::ostringstream out(std::ios::binary);
  openvdb::io::Stream(out).write({grid});
  std::string bytes = std::move(out).str();
  bytes.replace(21, 36, 36, '\0');
  return bytes;
}

/// A volume of `dims` with noise, a constant block, a block of background, -0 and scattered background voxels.
template <typename T>
std::vector<T> mixedVolume(const Vec3i& dims, T background) {
  std::vector<T> v(size_t(dims.volume()));
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> pick(0, 200);
  for (int64_t z = 0; z < dims.z; ++z)
    for (int64_t y = 0; y < dims.y; ++y)
      for (int64_t x = 0; x < dims.x; ++x) {
        T& value = v[size_t((z * dims.y + y) * dims.x + x)];
        if (x < 16 && y < 16)
          value = T(7);  // constant columns: tiles where a whole leaf falls inside
        else if (x >= 16 && x < 24 && y < 8)
          value = background;  // no leaf
        else if (pick(rng) < 20)
          value = background;
        else
          value = T(pick(rng));
        if constexpr (std::is_floating_point_v<T>)
          if (x == 20 && y == 12) value = -0.0f;
      }
  return v;
}

/// Feeds `values` to both routes in batches of `batches` slices (cycled) and expects the same file.
template <typename T>
void expectSameTree(const Vec3i& dims, float background, const std::vector<int64_t>& batches) {
  openvdb::initialize();
  const std::vector<T> values = mixedVolume<T>(dims, static_cast<T>(background));
  openvdb::FloatTree viaOpenVdb(background), direct(background);
  int64_t z = 0;
  for (size_t i = 0; z < dims.z; ++i) {
    const int64_t count = std::min(batches[i % batches.size()], dims.z - z);
    const T* first = values.data() + z * dims.x * dims.y;
    const openvdb::CoordBBox box(openvdb::Coord(0, 0, int(z)),
                                 openvdb::Coord(int(dims.x - 1), int(dims.y - 1), int(z + count - 1)));
    const openvdb::tools::Dense<T, openvdb::tools::LayoutXYZ> dense(box, const_cast<T*>(first));
    openvdb::tools::copyFromDense(dense, viaOpenVdb, 0.0f);
    addSlicesToTree(direct, first, dims, z, count);
    z += count;
  }
  EXPECT_GT(direct.leafCount(), 0u);
  EXPECT_EQ(direct.leafCount(), viaOpenVdb.leafCount());
  EXPECT_EQ(direct.activeVoxelCount(), viaOpenVdb.activeVoxelCount());
  EXPECT_EQ(direct.background(), background);
  EXPECT_TRUE(fileBytes(direct) == fileBytes(viaOpenVdb));
  // And voxel for voxel against the input itself.
  openvdb::tree::ValueAccessor<const openvdb::FloatTree> acc(direct);
  for (int64_t k = 0; k < dims.z; ++k)
    for (int64_t j = 0; j < dims.y; ++j)
      for (int64_t i = 0; i < dims.x; ++i) {
        const float v = static_cast<float>(values[size_t((k * dims.y + j) * dims.x + i)]);
        const openvdb::Coord c{int(i), int(j), int(k)};
        ASSERT_EQ(acc.isValueOn(c), v != background) << i << "," << j << "," << k;
        ASSERT_EQ(acc.getValue(c), v != background ? v : background);
      }
}

TEST(VdbSlices, AlignedBatchesOfWholeLeaves) { expectSameTree<float>({40, 32, 48}, 0.0f, {16}); }

TEST(VdbSlices, BatchesStartingAndEndingInsideLeaves) {
  expectSameTree<float>({37, 29, 70}, 0.0f, {33, 32, 5, 3, 1, 11});
}

TEST(VdbSlices, OtherBackground) { expectSameTree<float>({30, 20, 50}, 7.0f, {9, 8}); }

TEST(VdbSlices, IntegerTypes) {
  expectSameTree<uint8_t>({33, 24, 41}, 0.0f, {17, 8});
  expectSameTree<uint16_t>({24, 40, 19}, 3.0f, {4});
  expectSameTree<int16_t>({40, 16, 64}, 0.0f, {64});
}

}  // namespace
}  // namespace voxbrick::store
