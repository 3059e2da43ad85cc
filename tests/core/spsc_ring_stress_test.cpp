// Two threads hammer one ring; every sequence number must arrive exactly once and in order, or be
// counted as dropped. Also built under ThreadSanitizer (ctest label "tsan").
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <thread>
#include <vector>

#include "core/sample.hpp"
#include "core/spsc_ring.hpp"

namespace {

std::uint64_t iterations() {
  const char* env = std::getenv("GUIDEWAY_STRESS_ITEMS");
  return env ? std::strtoull(env, nullptr, 10) : 2'000'000;
}

struct Result {
  std::uint64_t received = 0;
  std::uint64_t gaps = 0;
  bool in_order = true;
};

// The consumer checks order and counts the holes that drops leave in the sequence.
Result consume(guideway::SpscRing<guideway::Sample>& ring, std::atomic<bool>& done, bool bulk) {
  Result r;
  std::uint64_t expected = 0;
  std::vector<guideway::Sample> buf(64);
  auto take = [&](const guideway::Sample& s) {
    if (s.seq < expected) r.in_order = false;
    r.gaps += s.seq - expected;
    expected = s.seq + 1;
    ++r.received;
    if (s.value[0] != static_cast<double>(s.seq)) r.in_order = false;  // payload travels with its number
  };
  for (;;) {
    const bool finished = done.load(std::memory_order_acquire);
    std::size_t n = 0;
    if (bulk) {
      n = ring.pop_bulk(buf);
      for (std::size_t i = 0; i < n; ++i) take(buf[i]);
    } else {
      guideway::Sample s;
      while (ring.try_pop(s)) {
        take(s);
        ++n;
      }
    }
    if (n == 0 && finished) {
      // The producer is done and the ring was empty after we saw that: nothing more can come.
      if (ring.depth() == 0) break;
    }
  }
  return r;
}

void run_stress(std::size_t capacity, bool bulk_producer, bool bulk_consumer, bool slow_consumer) {
  guideway::SpscRing<guideway::Sample> ring(capacity);
  std::atomic<bool> done{false};
  const std::uint64_t total = iterations();
  Result result;
  std::thread consumer([&] {
    if (slow_consumer) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    result = consume(ring, done, bulk_consumer);
  });
  std::uint64_t accepted = 0;
  std::vector<guideway::Sample> chunk(37);  // odd size: splits at every wrap position
  for (std::uint64_t seq = 0; seq < total;) {
    if (bulk_producer) {
      const std::size_t n = std::min<std::uint64_t>(chunk.size(), total - seq);
      for (std::size_t i = 0; i < n; ++i) {
        chunk[i].seq = seq + i;
        chunk[i].value[0] = static_cast<double>(seq + i);
      }
      accepted += ring.push_bulk(std::span<const guideway::Sample>(chunk.data(), n));
      seq += n;
    } else {
      guideway::Sample s;
      s.seq = seq;
      s.value[0] = static_cast<double>(seq);
      accepted += ring.try_push(s) ? 1 : 0;
      ++seq;
    }
  }
  done.store(true, std::memory_order_release);
  consumer.join();
  EXPECT_TRUE(result.in_order);
  EXPECT_EQ(result.received, accepted);
  EXPECT_EQ(accepted + ring.drops(), total);
  // Gaps seen by the consumer are exactly the drops, except drops after the last received item.
  EXPECT_LE(result.gaps, ring.drops());
}

}  // namespace

TEST(SpscRingStress, SingleItemsLargeRing) { run_stress(1 << 16, false, false, false); }
TEST(SpscRingStress, SingleItemsTinyRingWithDrops) { run_stress(8, false, false, true); }
TEST(SpscRingStress, BulkBothSides) { run_stress(1 << 10, true, true, false); }
TEST(SpscRingStress, BulkProducerSingleConsumerTinyRing) { run_stress(64, true, false, true); }
TEST(SpscRingStress, SingleProducerBulkConsumer) { run_stress(256, false, true, false); }
