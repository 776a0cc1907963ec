// Admission: sessions, pending connections and per-address counts, and which pending connection gives way.
#include <gtest/gtest.h>

#include "server/Admission.h"

namespace voxbrick::server {
namespace {

using Result = Admission::Verdict::Result;

ConnectionId id(uint64_t n) { return ConnectionId{n}; }

TEST(Admission, PendingConnectionsDoNotCountAsSessions) {
  Admission a({/*maxSessions*/ 2, /*maxPending*/ 4, /*maxPerAddress*/ 0});
  for (uint64_t n = 1; n <= 4; ++n) EXPECT_EQ(a.admit(id(n), "10.0.0.1", true).result, Result::Pending);
  EXPECT_EQ(a.pending(), 4u);
  EXPECT_EQ(a.sessions(), 0u);
  EXPECT_TRUE(a.greet(id(1)));
  EXPECT_TRUE(a.greet(id(1))) << "idempotent";
  EXPECT_TRUE(a.greet(id(2)));
  EXPECT_EQ(a.sessions(), 2u);
  EXPECT_EQ(a.pending(), 2u);
  EXPECT_FALSE(a.greet(id(3))) << "max_sessions reached at Hello";
  EXPECT_EQ(a.admit(id(5), "10.0.0.2", true).result, Result::TooManySessions);
  a.remove(id(1));
  EXPECT_TRUE(a.greet(id(3)));
  a.remove(id(99));  // unknown: nothing
  EXPECT_EQ(a.sessions(), 2u);
}

TEST(Admission, AFullPendingQueueEvictsTheOldestOfTheBusiestAddress) {
  Admission a({64, 3, 0});
  a.admit(id(1), "good", true);
  a.admit(id(2), "flood", true);
  a.admit(id(3), "flood", true);
  const auto v = a.admit(id(4), "good", true);
  EXPECT_EQ(v.result, Result::Pending);
  ASSERT_TRUE(v.evicted);
  EXPECT_EQ(v.evicted->value, 2u) << "the flooding address gives way first, oldest first";
  EXPECT_EQ(a.pending(), 3u);
  EXPECT_FALSE(a.greet(id(2))) << "an evicted connection never becomes a session";
  EXPECT_EQ(a.fromAddress("flood"), 2u) << "counted until it closes";
  a.remove(id(2));
  EXPECT_EQ(a.fromAddress("flood"), 1u);
  EXPECT_EQ(a.pending(), 3u);
  // A tie between addresses: the oldest connection gives way.
  const auto w = a.admit(id(5), "other", true);
  ASSERT_TRUE(w.evicted);
  EXPECT_EQ(w.evicted->value, 1u);
  // Greeted connections are never evicted.
  EXPECT_TRUE(a.greet(id(3)));
  EXPECT_TRUE(a.greet(id(4)));
  EXPECT_TRUE(a.greet(id(5)));
  EXPECT_FALSE(a.admit(id(6), "x", true).evicted);
}

TEST(Admission, OneAddressHoldsAtMostItsLimitUnlessExempt) {
  Admission a({64, 16, 2});
  EXPECT_EQ(a.admit(id(1), "10.0.0.1", true).result, Result::Pending);
  EXPECT_TRUE(a.greet(id(1)));
  EXPECT_EQ(a.admit(id(2), "10.0.0.1", true).result, Result::Pending);
  EXPECT_EQ(a.admit(id(3), "10.0.0.1", true).result, Result::TooManyFromAddress);
  EXPECT_EQ(a.admit(id(4), "10.0.0.2", true).result, Result::Pending);
  EXPECT_EQ(a.admit(id(5), "10.0.0.1", false).result, Result::Pending) << "exempt (loopback)";
  a.remove(id(1));
  a.remove(id(5));
  EXPECT_EQ(a.admit(id(6), "10.0.0.1", true).result, Result::Pending);
  EXPECT_EQ(a.fromAddress("10.0.0.1"), 2u);
}

}  // namespace
}  // namespace voxbrick::server
