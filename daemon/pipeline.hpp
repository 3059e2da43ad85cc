#pragma once
// The pipeline: the single consumer of every driver ring, run on the I/O loop that serves the
// loop-driven drivers (drivers/io_loop.hpp), at the end of every pass, so what the devices read in a
// wake-up is processed in the same wake-up. It drains the rings in bulk, checks sequence gaps,
// measures sample-to-processing latency, feeds the stages (sessions, identification) and posts
// decimated SAMPLE messages to the outbox. Drivers on threads of their own wake the loop through a
// doorbell (drivers/doorbell.hpp) when it sleeps, and while their data flows it looks again in fixed
// coalescing steps instead. Thread safety: start/stop from the owner; progress() and stats() from
// any thread; the rest runs on the loop's thread.

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
#include "daemon/outbox.hpp"
#include "daemon/processing_chain.hpp"
#include "drivers/driver.hpp"
#include "drivers/io_loop.hpp"
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
  std::uint64_t consumed = 0;  // samples taken from the ring
  std::uint64_t seq_gaps = 0;  // samples missing by sequence number (ring overruns seen by the consumer)
  std::int64_t last_t_mono_ns = 0;
  std::uint64_t non_monotonic = 0;  // samples whose timestamp went backwards
};

struct PipelineStats {
  std::uint64_t iterations = 0;
  std::uint64_t samples = 0;
  double latency_mean_us = 0.0;  // sample timestamp to pipeline, over the last status period
  double latency_max_us = 0.0;
};

class Pipeline {
 public:
  // Runs on `loop` between start() and stop(); the loop must outlive them.
  Pipeline(std::vector<drivers::Driver*> devices, Outbox& outbox, double sample_publish_hz, drivers::IoLoop& loop);
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
  // Advances on every pass of the pipeline, idle or not: the watchdog's proof of life.
  [[nodiscard]] std::uint64_t progress() const noexcept { return progress_.load(std::memory_order_relaxed); }
  // Returns the period's statistics and restarts the latency window.
  PipelineStats take_stats();
  // The devices' cumulative flow counts as of now (a STATUS asked between two periods sees them
  // current, beside the drivers' live counters), leaving the period's figures alone.
  std::vector<DeviceFlowStats> device_flow() const;

  // While samples of drivers on threads of their own flow, the pipeline looks again this long after
  // it took some, so a wake-up carries a batch (bounds the added sample-to-pipeline latency). When a
  // look finds nothing it arms their doorbell instead: the next sample wakes the loop at once.
  static constexpr std::int64_t coalesce_ns = 400'000;
  // Longest time between passes: the stages' on_tick (session start/stop) runs at least this often.
  static constexpr std::int64_t idle_tick_ns = 5'000'000;

 private:
  void on_pass();  // the loop's end hook
  // One pass over every ring; returns samples taken, and sets `more` when a ring holds more than a batch.
  std::size_t drain_once(std::span<Sample> batch, bool& more, bool& from_threads);
  void publish_sample(std::size_t index, const Sample& raw, const Sample* processed, std::int64_t now_ns);

  std::vector<drivers::Driver*> devices_;
  std::vector<bool> threaded_;  // per device: on a thread of its own (rings the doorbell)
  Outbox& outbox_;
  drivers::IoLoop& loop_;
  std::int64_t publish_period_ns_;
  std::vector<std::int64_t> last_publish_ns_;
  std::vector<std::unique_ptr<PipelineStage>> stages_;
  std::vector<ProcessingChain> chains_;  // per device
  std::atomic<std::uint64_t> progress_{0};
  mutable std::mutex stats_mutex_;
  PipelineStats stats_;
  std::vector<DeviceFlowStats> flow_;  // per device, cumulative (under stats_mutex_)
  double latency_sum_us_ = 0.0;
  std::uint64_t latency_count_ = 0;
  std::vector<Sample> batch_;  // the loop thread's
  bool started_ = false;       // owner
  drivers::IoLoop::Id end_hook_ = 0;
  drivers::IoLoop::Id tick_timer_ = 0;
  drivers::IoLoop::Id coalesce_timer_ = 0;
  bool coalescing_ = false;                 // loop thread: the coalescing timer is armed
  alignas(64) drivers::Doorbell doorbell_;  // every threaded driver's publish touches it: its own cache line
};

}  // namespace guideway::daemon
