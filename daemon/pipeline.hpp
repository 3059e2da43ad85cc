#pragma once
// The pipeline thread: the single consumer of every driver ring. It drains the rings in bulk, checks
// sequence gaps, measures sample-to-processing latency, feeds the stages (sessions, identification)
// and posts decimated SAMPLE messages to the outbox. It sleeps on the drivers' doorbell
// when the rings are empty (drivers/doorbell.hpp) and in fixed coalescing steps while data flows.
// Thread safety: start/stop from the owner; progress() and stats() from any thread.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <stop_token>
#include <string>
#include <thread>
#include <vector>

#include "core/sample.hpp"
#include "daemon/processing_chain.hpp"
#include "daemon/outbox.hpp"
#include "drivers/driver.hpp"
#include "sessions/session.hpp"

namespace guideway::daemon {

// A processing stage fed by the pipeline thread (called only on that thread).
class PipelineStage {
 public:
  virtual ~PipelineStage() = default;
  // Every sample as it left the device's ring.
  virtual void on_samples(std::size_t device_index, const drivers::Driver& device, std::span<const Sample> samples) = 0;
  virtual void on_tick(std::int64_t now_mono_ns) { (void)now_mono_ns; }
};

struct DeviceFlowStats {
  std::uint64_t consumed = 0;     // samples taken from the ring
  std::uint64_t seq_gaps = 0;     // samples missing by sequence number (ring overruns seen by the consumer)
  std::int64_t last_t_mono_ns = 0;
  std::uint64_t non_monotonic = 0;  // samples whose timestamp went backwards
};

struct PipelineStats {
  std::uint64_t iterations = 0;
  std::uint64_t samples = 0;
  double latency_mean_us = 0.0;  // sample timestamp to pipeline, over the last status period
  double latency_max_us = 0.0;
  std::vector<DeviceFlowStats> devices;
};

class Pipeline {
 public:
  Pipeline(std::vector<drivers::Driver*> devices, Outbox& outbox, double sample_publish_hz);
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  void add_stage(std::unique_ptr<PipelineStage> stage);  // before start()
  // The [[processing]] steps of a device for the live SAMPLE stream (before start()). Sessions run
  // their own copy (SessionManager).
  void set_processing(std::size_t device_index, const std::vector<DenoiserSpec>& steps);
  // For STATUS (the steps' counters are thread safe).
  [[nodiscard]] const ProcessingChain& processing(std::size_t device_index) const { return chains_.at(device_index); }
  // Most samples the pipeline takes from a ring at once (the processing steps' max_batch): the batch
  // sessions are fed in, live and in a replay.
  static constexpr std::size_t max_batch = sessions::max_feed_batch;
  void start();
  void stop();
  // Advances on every loop of the pipeline thread, idle or not: the watchdog's proof of life.
  [[nodiscard]] std::uint64_t progress() const noexcept { return progress_.load(std::memory_order_relaxed); }
  // Returns the statistics and restarts the latency window.
  PipelineStats take_stats();

  // While samples flow the thread drains the rings, then sleeps this long before looking again, so
  // a wake-up carries a batch (bounds the added sample-to-pipeline latency). When a look finds
  // nothing it sleeps on the drivers' doorbell instead: the next sample wakes it at once.
  static constexpr std::int64_t coalesce_ns = 400'000;
  // Longest sleep on the doorbell: the stages' on_tick (session start/stop) runs at least this often.
  static constexpr std::int64_t idle_tick_ns = 5'000'000;

 private:
  void run(const std::stop_token& stop);
  std::size_t drain_once(std::span<Sample> batch);  // one pass over every ring; returns samples taken
  void publish_sample(std::size_t index, const Sample& raw, const Sample* processed, std::int64_t now_ns);

  std::vector<drivers::Driver*> devices_;
  Outbox& outbox_;
  std::int64_t publish_period_ns_;
  std::vector<std::int64_t> last_publish_ns_;
  std::vector<std::unique_ptr<PipelineStage>> stages_;
  std::vector<ProcessingChain> chains_;  // per device
  std::atomic<std::uint64_t> progress_{0};
  std::mutex stats_mutex_;
  PipelineStats stats_;
  double latency_sum_us_ = 0.0;
  std::uint64_t latency_count_ = 0;
  alignas(64) drivers::Doorbell doorbell_;  // every driver's publish touches it: its own cache line
  std::jthread thread_;
};

}  // namespace guideway::daemon
