#include "daemon/pipeline.hpp"

#include <array>
#include <algorithm>
#include <cmath>
#include <chrono>

#include <nlohmann/json.hpp>

#include "core/mono_clock.hpp"

namespace guideway::daemon {

Pipeline::Pipeline(std::vector<drivers::Driver*> devices, Outbox& outbox, double sample_publish_hz)
    : devices_(std::move(devices)),
      outbox_(outbox),
      publish_period_ns_(sample_publish_hz > 0 ? static_cast<std::int64_t>(1e9 / sample_publish_hz) : -1),
      last_publish_ns_(devices_.size(), 0),
      chains_(devices_.size()) {
  stats_.devices.resize(devices_.size());
  for (drivers::Driver* d : devices_) d->set_doorbell(&doorbell_);
}

Pipeline::~Pipeline() {
  stop();
  for (drivers::Driver* d : devices_) d->set_doorbell(nullptr);
}

void Pipeline::add_stage(std::unique_ptr<PipelineStage> stage) { stages_.push_back(std::move(stage)); }

void Pipeline::set_processing(std::size_t device_index, const std::vector<DenoiserSpec>& steps) {
  chains_.at(device_index) = ProcessingChain(steps, max_batch);
}

void Pipeline::start() {
  if (!thread_.joinable()) thread_ = std::jthread([this](std::stop_token stop) { run(stop); });
}

void Pipeline::stop() {
  if (!thread_.joinable()) return;
  thread_.request_stop();
  thread_.join();
}

PipelineStats Pipeline::take_stats() {
  std::lock_guard lock(stats_mutex_);
  PipelineStats out = stats_;
  out.latency_mean_us = latency_count_ ? latency_sum_us_ / static_cast<double>(latency_count_) : 0.0;
  // Figures over the period since the last call (protocol.md STATUS `pipeline`); the devices' flow
  // counts stay cumulative.
  latency_sum_us_ = 0.0;
  latency_count_ = 0;
  stats_.latency_max_us = 0.0;
  stats_.iterations = 0;
  stats_.samples = 0;
  return out;
}

void Pipeline::publish_sample(std::size_t index, const Sample& s, const Sample* processed, std::int64_t now_ns) {
  if (publish_period_ns_ < 0 || now_ns - last_publish_ns_[index] < publish_period_ns_) return;
  last_publish_ns_[index] = now_ns;
  const drivers::Driver& dev = *devices_[index];
  nlohmann::json j;
  j["device"] = dev.name();
  j["seq"] = s.seq;
  j["t_mono_ns"] = s.t_mono_ns;
  if (s.flags != 0) j["flags"] = s.flags;
  // A value that is not a number (no signal, over range) is left out, never null (protocol.md): the
  // flags say why it is missing.
  nlohmann::json values = nlohmann::json::object();
  for (std::size_t c = 0; c < s.value_count && c < dev.channels().size(); ++c) {
    if (std::isfinite(s.value[c])) values[dev.channels()[c].name] = s.value[c];
  }
  j["values"] = std::move(values);
  if (processed != nullptr) {
    // The newest denoised values (older than `seq` by the processors' latency): their own seq.
    nlohmann::json denoised = nlohmann::json::object();
    for (const auto& p : chains_[index].steps()) {
      if (p->channel() < processed->value_count && p->channel() < dev.channels().size() &&
          std::isfinite(processed->value[p->channel()])) {
        denoised[dev.channels()[p->channel()].name] = processed->value[p->channel()];
      }
    }
    j["denoised"] = {{"seq", processed->seq}, {"values", std::move(denoised)}};
  }
  outbox_.post(make_message(results::MessageClass::sample, std::move(j), dev.name()));
}

std::size_t Pipeline::drain_once(std::span<Sample> batch) {
  std::size_t total = 0;
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    const std::size_t n = devices_[i]->ring().pop_bulk(batch);
    if (n == 0) continue;
    total += n;
    const std::int64_t now = mono_now_ns();
    const std::span<const Sample> samples(batch.data(), n);
    {
      std::lock_guard lock(stats_mutex_);
      DeviceFlowStats& d = stats_.devices[i];
      for (const Sample& s : samples) {
        const std::uint64_t expected = d.consumed + d.seq_gaps;  // next sequence number if nothing was lost
        if (s.seq > expected) d.seq_gaps += s.seq - expected;
        if (s.t_mono_ns < d.last_t_mono_ns) ++d.non_monotonic;
        d.last_t_mono_ns = s.t_mono_ns;
        ++d.consumed;
        const double latency_us = static_cast<double>(now - s.t_mono_ns) * 1e-3;
        latency_sum_us_ += latency_us;
        ++latency_count_;
        if (latency_us > stats_.latency_max_us) stats_.latency_max_us = latency_us;
      }
      stats_.samples += n;
    }
    for (auto& stage : stages_) stage->on_samples(i, *devices_[i], samples);
    const Sample* newest_processed = nullptr;
    if (!chains_[i].empty()) {
      const std::span<const Sample> processed = chains_[i].process(samples);
      if (!processed.empty()) newest_processed = &processed.back();
    }
    publish_sample(i, samples.back(), newest_processed, now);
  }
  return total;
}

void Pipeline::run(const std::stop_token& stop) {
  std::array<Sample, max_batch> batch{};
  // stop() must not wait for a doorbell timeout.
  const std::stop_callback wake_on_stop(stop, [this] { doorbell_.ring(); });
  while (!stop.stop_requested()) {
    const std::size_t total = drain_once(batch);
    const std::int64_t now = mono_now_ns();
    for (auto& stage : stages_) stage->on_tick(now);
    {
      std::lock_guard lock(stats_mutex_);
      ++stats_.iterations;
    }
    progress_.fetch_add(1, std::memory_order_relaxed);
    if (total != 0) {
      // Data flows: let the next batch gather instead of waking per sample (one wake-up costs as much
      // as processing tens of samples).
      std::this_thread::sleep_for(std::chrono::nanoseconds(coalesce_ns));
      continue;
    }
    // Nothing came: sleep until a driver rings. Arm first, then look once more, so a sample
    // published in between is either seen here or rings the bell.
    doorbell_.arm();
    bool any = false;
    for (drivers::Driver* d : devices_) any = any || d->ring().depth() != 0;
    if (any || stop.stop_requested()) {
      doorbell_.disarm();
      continue;
    }
    doorbell_.wait_for(idle_tick_ns);
  }
}

}  // namespace guideway::daemon
