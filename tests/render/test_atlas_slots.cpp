// The atlas slot allocator without GL: LRU replacement, pinning for the current batch, residency and eviction
// reports, and the all-pinned answer that makes a frame draw in batches.
#include <gtest/gtest.h>

#include <set>

#include "render/core/RenderErrors.h"
#include "render/volume/AtlasSlots.h"

namespace voxbrick::render {
namespace {

store::BrickKey brick(int i) { return store::BrickKey{0, uint32_t(i), 0, 0}; }

TEST(AtlasSlots, RefusesAnEmptyAtlas) {
  EXPECT_THROW(AtlasSlots(0), RenderInputError);
  EXPECT_THROW(AtlasSlots(-3), RenderInputError);
}

TEST(AtlasSlots, FillsEverySlotOnceBeforeEvicting) {
  AtlasSlots slots(4);
  std::set<int> used;
  for (int i = 0; i < 4; ++i) {
    const auto a = slots.acquire(brick(i));
    ASSERT_TRUE(a);
    EXPECT_FALSE(a->resident);
    EXPECT_FALSE(a->evicted);
    used.insert(a->slot.index);
  }
  EXPECT_EQ(used, (std::set<int>{0, 1, 2, 3}));
  EXPECT_EQ(slots.pinned(), 4);
}

TEST(AtlasSlots, AResidentBrickKeepsItsSlotAndNeedsNoUpload) {
  AtlasSlots slots(3);
  const auto first = slots.acquire(brick(7));
  slots.unpinAll();
  const auto again = slots.acquire(brick(7));
  ASSERT_TRUE(again);
  EXPECT_TRUE(again->resident);
  EXPECT_EQ(again->slot, first->slot);
  EXPECT_TRUE(slots.resident(brick(7)));
  EXPECT_FALSE(slots.resident(brick(8)));
}

TEST(AtlasSlots, EvictsTheLeastRecentlyUsed) {
  AtlasSlots slots(3);
  for (int i = 0; i < 3; ++i) slots.acquire(brick(i));
  slots.unpinAll();
  slots.acquire(brick(0));  // 0 becomes the most recently used; 1 is now the oldest
  slots.unpinAll();
  const auto a = slots.acquire(brick(3));
  ASSERT_TRUE(a);
  ASSERT_TRUE(a->evicted);
  EXPECT_EQ(*a->evicted, brick(1));
  EXPECT_FALSE(slots.resident(brick(1)));
  EXPECT_TRUE(slots.resident(brick(0)));
  const auto b = slots.acquire(brick(4));
  ASSERT_TRUE(b && b->evicted);
  EXPECT_EQ(*b->evicted, brick(2));
}

TEST(AtlasSlots, PinnedSlotsAreNeverTakenAndAFullBatchAnswersNothing) {
  AtlasSlots slots(2);
  ASSERT_TRUE(slots.acquire(brick(0)));
  ASSERT_TRUE(slots.acquire(brick(1)));
  EXPECT_FALSE(slots.acquire(brick(2))) << "both slots belong to the batch being built";
  EXPECT_TRUE(slots.resident(brick(0)));
  EXPECT_TRUE(slots.resident(brick(1)));
  // A pinned, resident brick can still be acquired again within the batch.
  const auto again = slots.acquire(brick(1));
  ASSERT_TRUE(again);
  EXPECT_TRUE(again->resident);
  EXPECT_EQ(slots.pinned(), 2);
  slots.unpinAll();
  EXPECT_EQ(slots.pinned(), 0);
  const auto c = slots.acquire(brick(2));
  ASSERT_TRUE(c && c->evicted);
  EXPECT_EQ(*c->evicted, brick(0)) << "brick 0 was used least recently";
}

TEST(AtlasSlots, PinningSkipsToTheOldestUnpinnedSlot) {
  AtlasSlots slots(3);
  for (int i = 0; i < 3; ++i) slots.acquire(brick(i));
  slots.unpinAll();
  slots.acquire(brick(0));  // pinned, and no longer the oldest
  const auto a = slots.acquire(brick(5));
  ASSERT_TRUE(a && a->evicted);
  EXPECT_EQ(*a->evicted, brick(1));
  const auto b = slots.acquire(brick(6));
  ASSERT_TRUE(b && b->evicted);
  EXPECT_EQ(*b->evicted, brick(2));
  EXPECT_FALSE(slots.acquire(brick(7)));
}

TEST(AtlasSlots, ClearForgetsEveryBrick) {
  AtlasSlots slots(2);
  slots.acquire(brick(0));
  slots.acquire(brick(1));
  slots.clear();
  EXPECT_EQ(slots.pinned(), 0);
  EXPECT_FALSE(slots.resident(brick(0)));
  const auto a = slots.acquire(brick(0));
  ASSERT_TRUE(a);
  EXPECT_FALSE(a->resident);
  EXPECT_FALSE(a->evicted) << "a cleared slot holds nothing to evict";
}

TEST(AtlasSlots, ManyFramesNeverLoseTrackOfResidency) {
  // A frame of 10 bricks through 4 slots, repeated: each frame pages every brick, in batches of 4.
  AtlasSlots slots(4);
  for (int frame = 0; frame < 3; ++frame) {
    int batches = 1;
    for (int i = 0; i < 10; ++i) {
      auto a = slots.acquire(brick(i));
      if (!a) {
        slots.unpinAll();
        ++batches;
        a = slots.acquire(brick(i));
      }
      ASSERT_TRUE(a);
      EXPECT_TRUE(slots.resident(brick(i)));
    }
    slots.unpinAll();
    EXPECT_EQ(batches, 3) << "10 bricks in batches of at most 4";
  }
}

}  // namespace
}  // namespace voxbrick::render
