// The single consumer of every driver ring (pipeline.hpp): sequence gaps, latency, the stages, SAMPLE messages.
#include "daemon/pipeline.hpp"

#include <sys/epoll.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include <nlohmann/json.hpp>

#include "core/mono_clock.hpp"

namespace guideway::daemon {

Pipeline::Pipeline(std::vector<drivers::Driver*> devices, Outbox& outbox, double sample_publish_hz,
                   drivers::IoLoop& loop)
    : devices_(std::move(devices)),
      outbox_(outbox),
      loop_(loop),
      publish_period_ns_(sample_publish_hz > 0 ? static_cast<std::int64_t>(1e9 / sample_publish_hz) : -1),
      last_publish_ns_(devices_.size(), 0),
      chains_(devices_.size()),
      batch_(max_batch) {
  flow_.resize(devices_.size());
  // Loop-driven drivers are served by this loop and publish in its passes: no doorbell for them.
  for (drivers::Driver* d : devices_) {
    threaded_.push_back(!d->loop_driven());
    if (threaded_.back()) d->set_doorbell(&doorbell_);
  }
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
  if (started_) return;
  started_ = true;
  loop_.call([this] {
    tick_timer_ = loop_.add_timer([] {});  // a pass at least every idle_tick_ns: its end hook is the work
    coalesce_timer_ = loop_.add_timer([this] { coalescing_ = false; });
    loop_.watch(doorbell_.fd(), EPOLLIN, [this](std::uint32_t) { doorbell_.clear(); });
    end_hook_ = loop_.add_end_hook([this] { on_pass(); });
    loop_.again();
  });
}

void Pipeline::stop() {
  if (!started_) return;
  started_ = false;
  loop_.call([this] {
    loop_.remove_hook(end_hook_);
    loop_.remove_timer(tick_timer_);
    loop_.remove_timer(coalesce_timer_);
    loop_.unwatch(doorbell_.fd());
    doorbell_.disarm();
  });
}

PipelineStats Pipeline::take_stats() {
  std::lock_guard lock(stats_mutex_);
  PipelineStats out = stats_;
  out.latency_mean_us = latency_count_ ? latency_sum_us_ / static_cast<double>(latency_count_) : 0.0;
  // Figures over the period since the last call (protocol.md STATUS `pipeline`); the devices' flow
  // counts are device_flow()'s.
  latency_sum_us_ = 0.0;
  latency_count_ = 0;
  stats_.latency_max_us = 0.0;
  stats_.iterations = 0;
  stats_.samples = 0;
  return out;
}

std::vector<DeviceFlowStats> Pipeline::device_flow() const {
  std::lock_guard lock(stats_mutex_);
  return flow_;
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

std::size_t Pipeline::drain_once(std::span<Sample> batch, bool& more, bool& from_threads) {
  std::size_t total = 0;
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    const std::size_t n = devices_[i]->ring().pop_bulk(batch);
    if (n == 0) continue;
    total += n;
    more = more || n == batch.size();
    from_threads = from_threads || threaded_[i];
    const std::int64_t now = mono_now_ns();
    const std::span<const Sample> samples(batch.data(), n);
    {
      std::lock_guard lock(stats_mutex_);
      DeviceFlowStats& d = flow_[i];
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

void Pipeline::on_pass() {
  bool more = false;
  bool from_threads = false;
  drain_once(batch_, more, from_threads);
  const std::int64_t now = mono_now_ns();
  for (auto& stage : stages_) stage->on_tick(now);
  {
    std::lock_guard lock(stats_mutex_);
    ++stats_.iterations;
  }
  progress_.fetch_add(1, std::memory_order_relaxed);
  loop_.arm(tick_timer_, now + idle_tick_ns);
  if (more) loop_.again();  // a backlog: on at once, after the devices had their turn
  if (from_threads) {
    // A threaded driver's data flows: let the next batch gather instead of a wake-up per sample (one
    // wake-up costs as much as processing tens of samples).
    if (!coalescing_) loop_.arm(coalesce_timer_, now + coalesce_ns);
    coalescing_ = true;
    doorbell_.disarm();
    return;
  }
  if (coalescing_ || std::find(threaded_.begin(), threaded_.end(), true) == threaded_.end()) return;
  // Nothing came from them: the next sample of theirs wakes the loop. Arm first, then look once more,
  // so a sample published in between is either seen here or rings the bell.
  doorbell_.arm();
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    if (threaded_[i] && devices_[i]->ring().depth() != 0) {
      doorbell_.disarm();
      loop_.again();
      return;
    }
  }
}

}  // namespace guideway::daemon
