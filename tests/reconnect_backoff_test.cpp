// The wait between a lost device's connection attempts (drivers/reconnect_backoff.hpp), shared by the
// four drivers: short after a working link, doubling per failure, never past its ceiling.
#include "drivers/reconnect_backoff.hpp"

#include <gtest/gtest.h>

using namespace std::chrono_literals;
using guideway::drivers::ReconnectBackoff;

TEST(ReconnectBackoff, DoublesPerFailureUpToItsCeilingAndStartsAgainAfterALink) {
  ReconnectBackoff b(100ms, 500ms);
  EXPECT_EQ(b.take(), 100ms);
  EXPECT_EQ(b.take(), 200ms);
  EXPECT_EQ(b.take(), 400ms);
  EXPECT_EQ(b.take(), 500ms);
  EXPECT_EQ(b.take(), 500ms);
  b.reset();
  EXPECT_EQ(b.take_ns(), 100'000'000);
  EXPECT_EQ(b.take_ns(), 200'000'000);
}

TEST(ReconnectBackoff, ACeilingBelowTheFirstWaitIsTheFirstWait) {
  ReconnectBackoff b(300ms, 100ms);
  EXPECT_EQ(b.take(), 300ms);
  EXPECT_EQ(b.take(), 300ms);
}
