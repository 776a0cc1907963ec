// A chunk's .vdb file written from its cut leaves (VdbLeafChunk) against OpenVDB's own writer on the tree
// tools::copyFromDense and tools::pruneTiles build from the same box: the same bytes (the random file UUID apart),
// with partial leaves at every edge, tiles and pruned nodes, inactive voxels, NaNs, every value type, either
// compression, either background, chunks that start and end inside a leaf, and slices given in calls of any size.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/Prune.h>

#include "brickstore/vdb/VdbLeafChunk.h"
#include "support/TestSupport.h"

namespace voxbrick::store {
namespace {

std::string fileText(const std::filesystem::path& path) {
  const std::vector<char> bytes = test::readFile(path);
  return {bytes.begin(), bytes.end()};
}

/// The grid a chunk file describes: name, class, transform and metadata as prep sets them.
openvdb::FloatGrid::Ptr describedGrid(float background, int64_t z0) {
  auto grid = openvdb::FloatGrid::create(background);
  openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
  m.preScale(openvdb::Vec3d(0.5, 0.75, 1.25));
  m.postTranslate(openvdb::Vec3d(-3.0, 2.0, 0.5));
  grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
  grid->setName("density");
  grid->setGridClass(openvdb::GRID_FOG_VOLUME);
  grid->insertMeta("voxbrick_chunk_z0", openvdb::Int64Metadata(z0));
  return grid;
}

struct Case {
  Vec3i dims;
  int64_t z0, z1;
  float background;
  std::vector<int64_t> calls;  ///< slices a call, repeated over the chunk (empty: the whole chunk at once)
};

/// Writes slices [z0, z1) of `values` both ways and expects the same file. Returns the reference tree's node
/// counts (leaves first).
template <typename T>
std::vector<openvdb::Index32> expectSameFile(const std::vector<T>& values, const Case& c, bool blosc,
                                             const std::string& what) {
  openvdb::initialize();
  const test::ScratchDir dir;
  const int64_t slice = c.dims.x * c.dims.y;

  // OpenVDB: the chunk's box copied from a dense grid, constant nodes pruned, written by io::File.
  openvdb::FloatGrid::Ptr reference = describedGrid(c.background, c.z0);
  const openvdb::CoordBBox box(openvdb::Coord(0, 0, int(c.z0)),
                               openvdb::Coord(int(c.dims.x - 1), int(c.dims.y - 1), int(c.z1 - 1)));
  const openvdb::tools::Dense<const T, openvdb::tools::LayoutXYZ> dense(box, values.data() + c.z0 * slice);
  openvdb::tools::copyFromDense(dense, reference->tree(), T(0), false);
  openvdb::tools::pruneTiles(reference->tree(), 0.0f);
  {
    openvdb::io::File file((dir / "reference.vdb").string());
    if (!blosc) file.setCompression(openvdb::io::COMPRESS_ACTIVE_MASK);
    file.write({reference});
  }

  // Without the tree.
  VdbLeafChunk chunk(c.dims, c.background);
  chunk.begin(c.z0, c.z1);
  for (int64_t z = c.z0, k = 0; z < c.z1; ++k) {
    const int64_t n = c.calls.empty() ? c.z1 - z : std::min(c.calls[size_t(k) % c.calls.size()], c.z1 - z);
    EXPECT_FALSE(chunk.complete());
    chunk.addSlices(values.data() + z * slice, z, n);
    z += n;
  }
  EXPECT_TRUE(chunk.complete());
  const int64_t leaves = chunk.leafCount();
  const int64_t size = chunk.write(dir / "chunk.vdb", *describedGrid(c.background, c.z0), blosc);

  std::string expected = fileText(dir / "reference.vdb"), got = fileText(dir / "chunk.vdb");
  EXPECT_EQ(size, int64_t(got.size())) << what;
  EXPECT_EQ(leaves, int64_t(reference->tree().leafCount())) << what;
  // The 36-character UUID after the magic number, the versions and the offsets flag.
  if (expected.size() > 57) expected.replace(21, 36, 36, '\0');
  if (got.size() > 57) got.replace(21, 36, 36, '\0');
  EXPECT_EQ(got.size(), expected.size()) << what;
  EXPECT_TRUE(got == expected) << what << ": first difference at byte "
                               << std::mismatch(got.begin(), got.end(), expected.begin(), expected.end()).first -
                                      got.begin();
  return reference->tree().nodeCount();
}

/// Noise with a third of the voxels at the background, a few NaNs, constant 8^3 blocks (tiles), the value minus
/// the background and both zeros.
std::vector<float> mixed(const Vec3i& dims, float background) {
  std::vector<float> v(size_t(dims.volume()));
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int64_t z = 0; z < dims.z; ++z)
    for (int64_t y = 0; y < dims.y; ++y)
      for (int64_t x = 0; x < dims.x; ++x) {
        float& out = v[size_t(x + dims.x * (y + dims.y * z))];
        const float r = u(rng);
        if (x >= 16 && x < 24 && y < 16)
          out = 0.75f;  // whole blocks of one value: tiles
        else if (x >= 24 && x < 32 && y < 8)
          out = (x + y + z) % 2 ? 0.0f : -0.0f;  // tiles of +-0
        else if (r < -0.33f)
          out = background;
        else if (r < -0.32f)
          out = std::numeric_limits<float>::quiet_NaN();
        else if (r < -0.30f)
          out = -background;
        else
          out = r;
      }
  return v;
}

TEST(VdbLeafChunk, SameBytesAsOpenVdbWithPartialLeavesAndTiles) {
  const Vec3i dims{70, 45, 37};
  for (const float background : {0.0f, -3.25f})
    for (const bool blosc : {false, true}) {
      const std::vector<float> v = mixed(dims, background);
      const std::string what = "background " + std::to_string(background) + (blosc ? ", blosc" : ", mask only");
      EXPECT_GT(expectSameFile(v, {dims, 0, 37, background, {}}, blosc, what).at(0), 40u);
    }
}

// Blocks without a background voxel are cut by a faster path (copied, then transposed): noise in [1, 2) and a
// ramp of 16-bit values, every voxel active.
TEST(VdbLeafChunk, SameBytesWhereEveryVoxelIsActive) {
  const Vec3i dims{48, 40, 24};
  std::vector<float> noise(size_t(dims.volume()));
  std::vector<uint16_t> ramp(noise.size());
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(1.0f, 2.0f);
  for (size_t i = 0; i < noise.size(); ++i) noise[i] = u(rng), ramp[i] = uint16_t(1 + i % 4099);
  EXPECT_EQ(expectSameFile(noise, {dims, 0, 24, 0.0f, {}}, false, "noise").at(0), 6u * 5u * 3u);
  EXPECT_EQ(expectSameFile(noise, {dims, 8, 24, 0.0f, {8}}, true, "noise, blosc").at(0), 6u * 5u * 2u);
  EXPECT_EQ(expectSameFile(ramp, {dims, 0, 24, 0.0f, {16}}, false, "ramp").at(0), 6u * 5u * 3u);
}

TEST(VdbLeafChunk, SameBytesForChunksInsideLeavesGivenInCallsOfAnySize) {
  const Vec3i dims{41, 33, 61};
  const std::vector<float> v = mixed(dims, 0.0f);
  EXPECT_GT(expectSameFile(v, {dims, 5, 29, 0.0f, {1, 3, 7, 13}}, false, "z 5..29 in odd calls").at(0), 10u);
  EXPECT_GT(expectSameFile(v, {dims, 29, 61, 0.0f, {8}}, true, "z 29..61 a leaf a call").at(0), 10u);
  EXPECT_GT(expectSameFile(v, {dims, 16, 24, 0.0f, {2}}, false, "one leaf layer").at(0), 10u);
  EXPECT_GT(expectSameFile(v, {dims, 60, 61, 0.0f, {}}, false, "the last slice alone").at(0), 10u);
}

// A 128^3 node whose every 8^3 block is a tile of one value is pruned to a tile of the node above, with the value
// tools::pruneTiles picks; beside it nodes of noise and of another value at the edge, which are not.
TEST(VdbLeafChunk, SameBytesWhereWholeNodesArePruned) {
  const Vec3i dims{136, 130, 128};
  std::vector<float> v(size_t(dims.volume()), 2.5f);
  for (int64_t z = 0; z < dims.z; ++z)
    for (int64_t y = 0; y < dims.y; ++y)
      for (int64_t x = 128; x < dims.x; ++x) v[size_t(x + dims.x * (y + dims.y * z))] = float((x + y + z) % 3);
  for (int64_t z = 0; z < 8; ++z)  // another value at the edge: a leaf, not a tile
    for (int64_t y = 128; y < dims.y; ++y)
      for (int64_t x = 0; x < 8; ++x) v[size_t(x + dims.x * (y + dims.y * z))] = 7.0f;
  // Of the four 128^3 nodes the box meets, one is a tile.
  EXPECT_EQ(expectSameFile(v, {dims, 0, 128, 0.0f, {32}}, false, "pruned node").at(1), 3u);
  EXPECT_EQ(expectSameFile(v, {dims, 0, 128, 1.0f, {}}, true, "pruned node, blosc").at(1), 3u);
}

TEST(VdbLeafChunk, SameBytesForAnEmptyChunk) {
  const Vec3i dims{20, 12, 9};
  const std::vector<float> v(size_t(dims.volume()), 4.0f);
  EXPECT_EQ(expectSameFile(v, {dims, 0, 9, 4.0f, {}}, false, "all background").at(0), 0u);
  EXPECT_EQ(expectSameFile(v, {dims, 0, 9, 4.0f, {}}, true, "all background, blosc").at(0), 0u);
}

TEST(VdbLeafChunk, SameBytesForIntegerTypes) {
  const Vec3i dims{27, 19, 22};
  std::mt19937 rng(3);
  std::vector<uint8_t> u8(size_t(dims.volume()));
  std::vector<uint16_t> u16(u8.size());
  std::vector<int16_t> i16(u8.size());
  for (size_t i = 0; i < u8.size(); ++i) {
    const uint32_t r = rng();
    u8[i] = r % 4 == 0 ? 0 : uint8_t(r >> 8);
    u16[i] = r % 4 == 0 ? 0 : uint16_t(r >> 8);
    i16[i] = r % 4 == 0 ? int16_t(-7) : int16_t(r >> 12);
  }
  EXPECT_GT(expectSameFile(u8, {dims, 3, 22, 0.0f, {5}}, false, "u8").at(0), 10u);
  EXPECT_GT(expectSameFile(u16, {dims, 0, 22, 0.0f, {}}, true, "u16").at(0), 10u);
  EXPECT_GT(expectSameFile(i16, {dims, 0, 16, -7.0f, {16}}, false, "i16").at(0), 10u);
}

TEST(VdbLeafChunk, RefusesSlicesOutOfOrder) {
  const Vec3i dims{8, 8, 16};
  const std::vector<float> v(size_t(dims.volume()), 1.0f);
  VdbLeafChunk chunk(dims, 0.0f);
  chunk.begin(0, 16);
  EXPECT_THROW(chunk.addSlices(v.data(), 4, 2), std::logic_error);
  chunk.addSlices(v.data(), 0, 4);
  EXPECT_THROW(chunk.addSlices(v.data(), 4, 13), std::logic_error);
}

}  // namespace
}  // namespace voxbrick::store
