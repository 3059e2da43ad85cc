// The pipeline's doorbell (drivers/doorbell.hpp): a sleeping consumer is woken at once by a producer,
// a producer pays no wake-up while the consumer is awake, and the arm / look again / wait protocol
// never loses a wake-up with several producers (each wait would otherwise sit out its long timeout).
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <memory>
#include <thread>
#include <vector>

#include "core/sample.hpp"
#include "core/spsc_ring.hpp"
#include "drivers/doorbell.hpp"

using guideway::Sample;
using guideway::SpscRing;
using guideway::drivers::Doorbell;
using Clock = std::chrono::steady_clock;

TEST(Doorbell, ARingWakesASleepingConsumerLongBeforeItsTimeout) {
  Doorbell bell;
  std::atomic<bool> armed{false};
  std::thread producer([&] {
    while (!armed.load()) std::this_thread::yield();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    bell.ring();
  });
  bell.arm();
  armed = true;
  const auto start = Clock::now();
  bell.wait_for(10'000'000'000);  // 10 s
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(5));
  producer.join();
  EXPECT_EQ(bell.wakes(), 1u);
}

TEST(Doorbell, RingingAnAwakeConsumerCostsNoWakeUpAndAWaitStillTimesOut) {
  Doorbell bell;
  for (int i = 0; i < 1000; ++i) bell.ring();
  EXPECT_EQ(bell.wakes(), 0u);
  bell.arm();
  const auto start = Clock::now();
  bell.wait_for(20'000'000);  // 20 ms, nobody rings
  EXPECT_GE(Clock::now() - start, std::chrono::milliseconds(15));
  EXPECT_EQ(bell.wakes(), 0u);
}

TEST(Doorbell, NoWakeUpIsLostBetweenArmingAndWaitingWithSeveralProducers) {
  constexpr int producers = 3;
  constexpr std::uint64_t per_producer = 20000;
  std::vector<std::unique_ptr<SpscRing<Sample>>> rings;
  for (int i = 0; i < producers; ++i) rings.push_back(std::make_unique<SpscRing<Sample>>(1024));
  Doorbell bell;
  std::vector<std::thread> threads;
  for (int p = 0; p < producers; ++p) {
    threads.emplace_back([&, p] {
      for (std::uint64_t i = 0; i < per_producer; ++i) {
        Sample s;
        s.seq = i;
        while (!rings[static_cast<std::size_t>(p)]->try_push(s)) std::this_thread::yield();
        bell.ring();
        if (i % 64 == 0) std::this_thread::sleep_for(std::chrono::microseconds(50));  // let the consumer sleep
      }
    });
  }
  std::uint64_t consumed = 0;
  int long_waits = 0;
  std::array<Sample, 256> batch{};
  const auto start = Clock::now();
  while (consumed < producers * per_producer && Clock::now() - start < std::chrono::seconds(60)) {
    std::size_t got = 0;
    for (auto& r : rings) got += r->pop_bulk(batch);
    consumed += got;
    if (got != 0) continue;
    bell.arm();
    bool any = false;
    for (auto& r : rings) any = any || r->depth() != 0;
    if (any) {
      bell.disarm();
      continue;
    }
    const auto before = Clock::now();
    bell.wait_for(2'000'000'000);  // 2 s: a lost wake-up shows as a wait this long
    if (Clock::now() - before > std::chrono::milliseconds(1500)) ++long_waits;
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(consumed, producers * per_producer);
  EXPECT_EQ(long_waits, 0);
  EXPECT_GT(bell.wakes(), 0u);  // the consumer did sleep and was woken
}
