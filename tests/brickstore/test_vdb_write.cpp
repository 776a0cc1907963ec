// The parallel OpenVDB leaf-buffer writer against OpenVDB's own: the same file bytes for the same grid (random file
// UUID apart), with tiles, inactive voxels, several batches of leaves and either background.
#include <gtest/gtest.h>

#include <random>
#include <sstream>
#include <string>

#include <openvdb/io/Stream.h>

#include "brickstore/VdbParallelWrite.h"

namespace voxbrick::store {
namespace {

/// A grid of 130x90x70 voxels: noise, a constant active block (a tile once pruned), a block of inactive background
/// and scattered inactive voxels (the background, minus it, another value), so that every kind of leaf compression
/// occurs.
openvdb::FloatTree::Ptr mixedTree(float background) {
  auto tree = std::make_shared<openvdb::FloatTree>(background);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> value(-1.0f, 1.0f);
  auto acc = openvdb::tree::ValueAccessor<openvdb::FloatTree>(*tree);
  for (int z = 0; z < 70; ++z)
    for (int y = 0; y < 90; ++y)
      for (int x = 0; x < 130; ++x) {
        const openvdb::Coord c(x, y, z);
        if (x < 16 && y < 16 && z < 16) continue;  // left at the background: no leaf there
        if (x >= 64 && x < 80 && y < 16 && z < 16)
          acc.setValueOn(c, 0.5f);  // constant: pruned to a tile below
        else if (x >= 96 && y >= 80 && (x + y + z) % 13 == 0)
          acc.setValueOff(c, 2.0f);  // inactive, not the background
        else if (x >= 112 && y < 8 && (x + z) % 5 == 0)
          acc.setValueOff(c, -background);
        else if ((x * 7 + y * 3 + z) % 11 == 0)
          acc.setValueOff(c, background);
        else
          acc.setValueOn(c, value(rng));
      }
  tree->prune();
  return tree;
}

/// The file bytes io::Stream writes for `grid` with `compression` (OpenVDB's default: blosc and the active mask), with
/// the 36-character UUID at byte 21 blanked.
std::string fileBytes(const openvdb::GridBase::Ptr& grid,
                      uint32_t compression = openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK) {
  std::ostringstream out(std::ios::binary);
  openvdb::io::Stream stream(out);
  stream.setCompression(compression);
  stream.write({grid});
  std::string bytes = std::move(out).str();
  bytes.replace(21, 36, 36, '\0');
  return bytes;
}

void expectSameFile(float background,
                    uint32_t compression = openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK) {
  openvdb::initialize();
  openvdb::FloatTree::Ptr tree = mixedTree(background);
  ASSERT_GT(tree->leafCount(), 3u * 256u) << "the grid should span several batches of leaves";
  ASSERT_GT(tree->activeTileCount(), 0u);
  auto plain = openvdb::FloatGrid::create(tree);
  auto parallel = std::make_shared<ParallelWriteFloatGrid>(tree);
  for (openvdb::GridBase::Ptr g : {openvdb::GridBase::Ptr(plain), openvdb::GridBase::Ptr(parallel)}) {
    g->setName("density");
    g->setGridClass(openvdb::GRID_FOG_VOLUME);
  }
  const std::string expected = fileBytes(plain, compression);
  const std::string got = fileBytes(parallel, compression);
  ASSERT_EQ(got.size(), expected.size());
  EXPECT_TRUE(got == expected) << "first difference at byte "
                               << std::mismatch(got.begin(), got.end(), expected.begin()).first - got.begin();
}

TEST(VdbParallelWrite, SameBytesAsOpenVdbWithZeroBackground) { expectSameFile(0.0f); }

TEST(VdbParallelWrite, SameBytesAsOpenVdbWithOtherBackground) { expectSameFile(-3.25f); }

// Without blosc, leaves whose inactive values are all the background are copied out directly, the others (a voxel
// switched off with another value below) through OpenVDB's writer: the same bytes either way.
TEST(VdbParallelWrite, SameBytesAsOpenVdbWithoutBlosc) {
  expectSameFile(0.0f, openvdb::io::COMPRESS_ACTIVE_MASK);
  expectSameFile(-3.25f, openvdb::io::COMPRESS_ACTIVE_MASK);
}

TEST(VdbParallelWrite, SameBytesAsOpenVdbWithoutAnyCompression) { expectSameFile(0.0f, openvdb::io::COMPRESS_NONE); }

TEST(VdbParallelWrite, ReadsBackVoxelForVoxel) {
  openvdb::initialize();
  openvdb::FloatTree::Ptr tree = mixedTree(0.0f);
  auto grid = std::make_shared<ParallelWriteFloatGrid>(tree);
  std::ostringstream out(std::ios::binary);
  openvdb::io::Stream(out).write({grid});
  std::istringstream bytes(std::move(out).str(), std::ios::binary);
  openvdb::io::Stream in(bytes);
  auto back = openvdb::gridPtrCast<openvdb::FloatGrid>(in.getGrids()->at(0));
  ASSERT_TRUE(back);
  EXPECT_EQ(back->activeVoxelCount(), tree->activeVoxelCount());
  EXPECT_EQ(back->background(), 0.0f);
  auto a = back->getConstAccessor();
  auto b = openvdb::tree::ValueAccessor<const openvdb::FloatTree>(*tree);
  for (int z = 0; z < 72; ++z)
    for (int y = 0; y < 92; ++y)
      for (int x = 0; x < 132; ++x) {
        const openvdb::Coord c(x, y, z);
        ASSERT_EQ(a.getValue(c), b.getValue(c));
        ASSERT_EQ(a.isValueOn(c), b.isValueOn(c));
      }
}

}  // namespace
}  // namespace voxbrick::store
