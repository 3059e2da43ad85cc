// The wait between retries (core/backoff.hpp), the one back-off of the tree: a lost device's
// connection attempts, the broker's, an emulator's restarts. Short after a working link, doubling
// per failure, never past its ceiling.
#include "core/backoff.hpp"

#include <gtest/gtest.h>

using namespace std::chrono_literals;
using guideway::Backoff;

TEST(Backoff, DoublesPerFailureUpToItsCeilingAndStartsAgainAfterASuccess) {
  Backoff b = Backoff::between(100ms, 500ms);
  EXPECT_DOUBLE_EQ(b.take_s(), 0.1);
  EXPECT_DOUBLE_EQ(b.take_s(), 0.2);
  EXPECT_DOUBLE_EQ(b.take_s(), 0.4);
  EXPECT_DOUBLE_EQ(b.take_s(), 0.5);
  EXPECT_DOUBLE_EQ(b.take_s(), 0.5);
  b.reset();
  EXPECT_EQ(b.take_ns(), 100'000'000);
  EXPECT_EQ(b.take_ns(), 200'000'000);
}

TEST(Backoff, ACeilingBelowTheFirstWaitIsTheFirstWait) {
  Backoff b = Backoff::between(300ms, 100ms);
  EXPECT_EQ(b.take_ns(), 300'000'000);
  EXPECT_EQ(b.take_ns(), 300'000'000);
}

TEST(Backoff, SecondsAsTheBrokerAndTheEmulatorsGiveThem) {
  Backoff b{1.0, 60.0};
  for (const double want_s : {1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 60.0, 60.0}) EXPECT_DOUBLE_EQ(b.take_s(), want_s);
  b.reset();
  EXPECT_DOUBLE_EQ(b.take_s(), 1.0);
}
