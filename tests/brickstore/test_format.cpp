// Pins the byte layout of index.bin: offsets, sizes, magic, version.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstring>

#include "brickstore/format/StoreFormat.h"

namespace voxbrick::store {
namespace {

TEST(StoreFormat, IndexHeaderLayout) {
  EXPECT_EQ(std::memcmp(kIndexMagic, "VXBINDEX", 8), 0);
  EXPECT_EQ(kIndexVersion, 1u);
  EXPECT_EQ(sizeof(IndexHeader), 64u);
  EXPECT_EQ(offsetof(IndexHeader, version), 8u);
  EXPECT_EQ(offsetof(IndexHeader, levelCount), 12u);
  EXPECT_EQ(offsetof(IndexHeader, brickSize), 16u);
  EXPECT_EQ(offsetof(IndexHeader, valueType), 20u);
  EXPECT_EQ(offsetof(IndexHeader, bricksFileSize), 24u);
  EXPECT_EQ(offsetof(IndexHeader, recordCount), 32u);
  EXPECT_EQ(offsetof(IndexHeader, bodyCrc32), 40u);
  EXPECT_EQ(offsetof(IndexHeader, headerCrc32), 44u);
  EXPECT_EQ(offsetof(IndexHeader, reserved), 48u);
}

TEST(StoreFormat, LevelEntryAndBrickRecordLayout) {
  EXPECT_EQ(sizeof(LevelEntry), 48u);
  EXPECT_EQ(offsetof(LevelEntry, bricks), 24u);
  EXPECT_EQ(offsetof(LevelEntry, firstRecord), 40u);
  EXPECT_EQ(sizeof(BrickRecord), 32u);
  EXPECT_EQ(offsetof(BrickRecord, compressedSize), 8u);
  EXPECT_EQ(offsetof(BrickRecord, flags), 12u);
  EXPECT_EQ(offsetof(BrickRecord, min), 16u);
  EXPECT_EQ(offsetof(BrickRecord, max), 20u);
  EXPECT_EQ(offsetof(BrickRecord, reserved), 24u);
}

}  // namespace
}  // namespace voxbrick::store
