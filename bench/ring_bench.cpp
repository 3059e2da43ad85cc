// SPSC ring throughput, side by side with the queues a user would otherwise pick:
// boost::lockfree::spsc_queue and moodycamel::ReaderWriterQueue. Producer and consumer on two threads.
// Items are a 16-byte sample (sequence number + value) and the daemon's 64-byte Sample.
#include <benchmark/benchmark.h>

#include <atomic>
#include <thread>
#include <vector>

#include <boost/lockfree/spsc_queue.hpp>
#include <readerwriterqueue/readerwriterqueue.h>

#include "core/sample.hpp"
#include "core/spsc_ring.hpp"

namespace {

struct Sample16 {
  std::uint64_t seq;
  double value;
};
static_assert(sizeof(Sample16) == 16);

constexpr std::size_t capacity = 1 << 14;
constexpr std::size_t items_per_iteration = 1 << 20;
constexpr std::size_t bulk_size = 64;

// Adapters with one shape: try_push / try_pop, and bulk where the queue has it.
template <class T>
struct GuidewayQueue {
  guideway::SpscRing<T> q{capacity};
  bool push(const T& v) { return q.try_push(v); }
  bool pop(T& v) { return q.try_pop(v); }
  std::size_t push_bulk(const T* p, std::size_t n) { return q.try_push_bulk(std::span<const T>(p, n)); }
  std::size_t pop_bulk(T* p, std::size_t n) { return q.pop_bulk(std::span<T>(p, n)); }
};

template <class T>
struct BoostQueue {
  boost::lockfree::spsc_queue<T, boost::lockfree::capacity<capacity>> q;
  bool push(const T& v) { return q.push(v); }
  bool pop(T& v) { return q.pop(v); }
  std::size_t push_bulk(const T* p, std::size_t n) { return q.push(p, n); }
  std::size_t pop_bulk(T* p, std::size_t n) { return q.pop(p, n); }
};

template <class T>
struct MoodycamelQueue {
  moodycamel::ReaderWriterQueue<T> q{capacity};
  bool push(const T& v) { return q.try_enqueue(v); }  // try_: never allocates, like the others
  bool pop(T& v) { return q.try_dequeue(v); }
  std::size_t push_bulk(const T* p, std::size_t n) {  // no bulk API: a loop is what a user writes
    std::size_t i = 0;
    while (i < n && q.try_enqueue(p[i])) ++i;
    return i;
  }
  std::size_t pop_bulk(T* p, std::size_t n) {
    std::size_t i = 0;
    while (i < n && q.try_dequeue(p[i])) ++i;
    return i;
  }
};

template <class Queue, class T, bool Bulk>
void BM_Transfer(benchmark::State& state) {
  auto queue = std::make_unique<Queue>();
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> consumed{0};
  std::thread consumer([&] {
    std::vector<T> buf(bulk_size);
    std::uint64_t n = 0;
    std::uint64_t checksum = 0;
    while (!stop.load(std::memory_order_relaxed)) {
      if constexpr (Bulk) {
        const std::size_t got = queue->pop_bulk(buf.data(), buf.size());
        for (std::size_t i = 0; i < got; ++i) checksum += buf[i].seq;
        n += got;
      } else {
        T v;
        if (queue->pop(v)) {
          checksum += v.seq;
          ++n;
        }
      }
      consumed.store(n, std::memory_order_release);
    }
    benchmark::DoNotOptimize(checksum);
  });
  std::vector<T> chunk(bulk_size);
  std::uint64_t seq = 0;
  for (auto _ : state) {
    const std::uint64_t target = seq + items_per_iteration;
    while (seq < target) {
      if constexpr (Bulk) {
        for (std::size_t i = 0; i < bulk_size; ++i) chunk[i].seq = seq + i;
        std::size_t done = 0;
        while (done < bulk_size) done += queue->push_bulk(chunk.data() + done, bulk_size - done);
        seq += bulk_size;
      } else {
        T v{};
        v.seq = seq;
        while (!queue->push(v)) {
        }
        ++seq;
      }
    }
    while (consumed.load(std::memory_order_acquire) < seq) {
    }
  }
  stop.store(true);
  consumer.join();
  state.SetItemsProcessed(static_cast<std::int64_t>(seq));
  state.SetBytesProcessed(static_cast<std::int64_t>(seq * sizeof(T)));
}

using S16 = Sample16;
using S64 = guideway::Sample;

}  // namespace

#define GW_BENCH(queue, type, bulk, label)                                                   \
  BENCHMARK_TEMPLATE(BM_Transfer, queue<type>, type, bulk)->Name(label)->UseRealTime()       \
      ->Unit(benchmark::kMillisecond)->MinTime(0.5)

GW_BENCH(GuidewayQueue, S16, false, "single16/guideway");
GW_BENCH(BoostQueue, S16, false, "single16/boost_spsc");
GW_BENCH(MoodycamelQueue, S16, false, "single16/moodycamel_rwq");
GW_BENCH(GuidewayQueue, S16, true, "bulk64x16/guideway");
GW_BENCH(BoostQueue, S16, true, "bulk64x16/boost_spsc");
GW_BENCH(MoodycamelQueue, S16, true, "bulk64x16/moodycamel_rwq");
GW_BENCH(GuidewayQueue, S64, false, "single64/guideway");
GW_BENCH(BoostQueue, S64, false, "single64/boost_spsc");
GW_BENCH(MoodycamelQueue, S64, false, "single64/moodycamel_rwq");
GW_BENCH(GuidewayQueue, S64, true, "bulk64x64/guideway");
GW_BENCH(BoostQueue, S64, true, "bulk64x64/boost_spsc");
GW_BENCH(MoodycamelQueue, S64, true, "bulk64x64/moodycamel_rwq");

BENCHMARK_MAIN();
