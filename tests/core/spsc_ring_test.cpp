// The SPSC ring on one thread (core/spsc_ring.hpp): order, depth, drops counted when full, bulk
// transfers split at the wrap (spsc_ring_stress_test runs it across threads).
#include "core/spsc_ring.hpp"

#include <gtest/gtest.h>

#include <array>
#include <numeric>
#include <vector>

#include "core/sample.hpp"

using guideway::SpscRing;

TEST(SpscRing, RejectsCapacityThatIsNotAPowerOfTwo) {
  EXPECT_THROW(SpscRing<int>(0), std::invalid_argument);
  EXPECT_THROW(SpscRing<int>(1), std::invalid_argument);
  EXPECT_THROW(SpscRing<int>(6), std::invalid_argument);
  EXPECT_NO_THROW(SpscRing<int>(8));
}

TEST(SpscRing, PushPopInOrderAndReportsDepth) {
  SpscRing<int> r(4);
  EXPECT_EQ(r.depth(), 0u);
  EXPECT_EQ(r.free_slots(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(r.try_push(i));
  EXPECT_EQ(r.depth(), 4u);
  EXPECT_EQ(r.free_slots(), 0u);
  int v = -1;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(r.try_pop(v));
    EXPECT_EQ(v, i);
  }
  EXPECT_FALSE(r.try_pop(v));
  EXPECT_EQ(r.drops(), 0u);
}

TEST(SpscRing, FullRingDropsNewItemsAndCountsThem) {
  SpscRing<int> r(2);
  EXPECT_TRUE(r.try_push(1));
  EXPECT_TRUE(r.try_push(2));
  EXPECT_FALSE(r.try_push(3));
  EXPECT_FALSE(r.try_push(4));
  EXPECT_EQ(r.drops(), 2u);
  int v = 0;
  ASSERT_TRUE(r.try_pop(v));
  EXPECT_EQ(v, 1);  // the oldest is kept: overrun drops the newest, never silently rewrites
  EXPECT_TRUE(r.try_push(5));
  ASSERT_TRUE(r.try_pop(v));
  EXPECT_EQ(v, 2);
  ASSERT_TRUE(r.try_pop(v));
  EXPECT_EQ(v, 5);
}

TEST(SpscRing, BulkTransfersSplitAtTheWrapPoint) {
  SpscRing<int> r(8);
  std::array<int, 5> in{};
  std::array<int, 8> out{};
  int next = 0;
  int expect = 0;
  // Walk the indices around the ring many times so every split position is exercised.
  for (int round = 0; round < 40; ++round) {
    std::iota(in.begin(), in.end(), next);
    ASSERT_EQ(r.push_bulk(in), in.size());
    next += static_cast<int>(in.size());
    const std::size_t n = r.pop_bulk(std::span<int>(out.data(), 5));
    ASSERT_EQ(n, 5u);
    for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(out[i], expect++);
  }
  EXPECT_EQ(r.drops(), 0u);
  EXPECT_EQ(r.pushed(), 200u);
  EXPECT_EQ(r.popped(), 200u);
}

TEST(SpscRing, BulkPushPushesWhatFitsAndCountsTheRestAsDrops) {
  SpscRing<int> r(8);
  std::vector<int> in(11);
  std::iota(in.begin(), in.end(), 0);
  EXPECT_EQ(r.push_bulk(in), 8u);
  EXPECT_EQ(r.drops(), 3u);
  std::vector<int> out(16);
  ASSERT_EQ(r.pop_bulk(out), 8u);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(out[static_cast<std::size_t>(i)], i);
  EXPECT_EQ(r.pop_bulk(out), 0u);
}

TEST(SpscRing, PopBulkReturnsOnlyWhatIsAvailable) {
  SpscRing<guideway::Sample> r(16);
  guideway::Sample s;
  s.seq = 7;
  r.try_push(s);
  std::array<guideway::Sample, 4> out{};
  EXPECT_EQ(r.pop_bulk(out), 1u);
  EXPECT_EQ(out[0].seq, 7u);
}

TEST(SpscRing, TryPushBulkLeavesTheRestToTheCallerWithoutCountingDrops) {
  SpscRing<int> r(4);
  std::vector<int> in{1, 2, 3, 4, 5, 6};
  EXPECT_EQ(r.try_push_bulk(in), 4u);
  EXPECT_EQ(r.drops(), 0u);
  int v = 0;
  ASSERT_TRUE(r.try_pop(v));
  EXPECT_EQ(r.try_push_bulk(std::span<const int>(in).subspan(4)), 1u);
  EXPECT_EQ(r.drops(), 0u);
  std::vector<int> out(8);
  ASSERT_EQ(r.pop_bulk(out), 4u);
  EXPECT_EQ(out[0], 2);
  EXPECT_EQ(out[3], 5);
}
