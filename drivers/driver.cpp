// The Driver base (driver.hpp): its thread or loop, its state, counters and ring, shared by every driver.
#include "drivers/driver.hpp"

#include <pthread.h>

#include <algorithm>
#include <condition_variable>
#include <utility>

#include "core/mono_clock.hpp"
#include "drivers/io_loop.hpp"

namespace guideway::drivers {

std::string_view to_string(DeviceState state) noexcept {
  switch (state) {
    case DeviceState::stopped:
      return "stopped";
    case DeviceState::connecting:
      return "connecting";
    case DeviceState::streaming:
      return "streaming";
    case DeviceState::lost:
      return "lost";
    case DeviceState::error:
      return "error";
  }
  return "unknown";
}

Driver::Driver(std::string name, std::string driver, std::vector<ChannelInfo> channels, std::size_t ring_capacity)
    : name_(std::move(name)), driver_(std::move(driver)), channels_(std::move(channels)), ring_(ring_capacity) {}

Driver::~Driver() = default;  // derived classes call stop() in their destructors, before their members go

void Driver::start(IoLoop* loop) {
  if (thread_.joinable() || loop_ != nullptr) return;
  set_state(DeviceState::connecting);
  const std::string thread_name = "gw-" + name_;  // ps -L, /proc/PID/task/TID/comm (15 characters)
  if (loop_driven()) {
    if (loop == nullptr) {
      own_loop_ = std::make_unique<IoLoop>();
      own_loop_->start(thread_name);
      loop = own_loop_.get();
    }
    loop_ = loop;
    loop_->call([this] { attach(*loop_); });
    return;
  }
  thread_ = std::jthread([this, thread_name](std::stop_token stop) {
    (void)::pthread_setname_np(::pthread_self(), thread_name.substr(0, 15).c_str());
    run(stop);
  });
}

void Driver::stop() {
  if (loop_ != nullptr) {
    loop_->call([this] { detach(); });
    if (own_loop_) {
      own_loop_->stop();
      own_loop_.reset();
    }
    loop_ = nullptr;
    set_state(DeviceState::stopped);
    return;
  }
  if (!thread_.joinable()) return;
  thread_.request_stop();
  interrupt();
  thread_.join();
  set_state(DeviceState::stopped);
}

void Driver::set_warnings(std::vector<std::string> warnings) {
  std::lock_guard lock(state_mutex_);
  warnings_ = std::move(warnings);
}

void Driver::set_config_warnings(std::vector<std::string> warnings) {
  std::lock_guard lock(state_mutex_);
  config_warnings_ = std::move(warnings);
}

DriverStatus Driver::status() const {
  DriverStatus s;
  s.name = name_;
  s.driver = driver_;
  {
    std::lock_guard lock(state_mutex_);
    s.state = state_;
    s.reason = reason_;
    s.warnings = warnings_;
    s.warnings.insert(s.warnings.end(), config_warnings_.begin(), config_warnings_.end());
  }
  apply_sample_bound(s);
  s.counters.samples = samples_.load(std::memory_order_relaxed);
  s.counters.frames = frames_.load(std::memory_order_relaxed);
  s.counters.bad_frames = bad_frames_.load(std::memory_order_relaxed);
  s.counters.timeouts = timeouts_.load(std::memory_order_relaxed);
  s.counters.reconnects = reconnects_.load(std::memory_order_relaxed);
  s.counters.overruns = ring_.drops();
  s.driver_counters = driver_counters();
  s.ring = {ring_.capacity(), ring_.depth(), ring_.free_slots(), ring_.drops()};
  return s;
}

void Driver::mark_link_up() {
  std::lock_guard lock(state_mutex_);
  link_up_ns_ = mono_now_ns();
  published_at_link_up_ = published_.load(std::memory_order_relaxed);
  bad_frames_at_link_up_ = bad_frames_.load(std::memory_order_relaxed);
}

void Driver::apply_sample_bound(DriverStatus& s) const {
  const std::int64_t bound_ns = sample_bound_ns_.load(std::memory_order_relaxed);
  if (s.state != DeviceState::streaming || bound_ns <= 0) return;
  std::int64_t link_up_ns = 0;
  std::uint64_t published_at_up = 0;
  std::uint64_t bad_at_up = 0;
  {
    std::lock_guard lock(state_mutex_);
    link_up_ns = link_up_ns_;
    published_at_up = published_at_link_up_;
    bad_at_up = bad_frames_at_link_up_;
  }
  // The count first (acquire, paired with publish()): the time read after it is that sample's or newer.
  const bool none_yet = published_.load(std::memory_order_acquire) == published_at_up;
  const std::int64_t last_ns = last_sample_ns_.load(std::memory_order_relaxed);
  const std::int64_t now = mono_now_ns();
  if (none_yet && now - link_up_ns < bound_ns) {
    s.state = DeviceState::connecting;
    s.reason = "waiting for the first sample";
  } else if (none_yet || now - last_ns > bound_ns) {
    s.state = DeviceState::lost;
    s.reason = "no sample for more than " + std::to_string(bound_ns / 1'000'000) + " ms";
  } else {
    return;
  }
  const std::uint64_t bad = bad_frames_.load(std::memory_order_relaxed) - bad_at_up;
  if (bad > 0) s.reason += " (" + std::to_string(bad) + " bad frames on this link)";
}

void Driver::set_state(DeviceState state, std::string reason) {
  std::lock_guard lock(state_mutex_);
  state_ = state;
  reason_ = std::move(reason);
}

void Driver::post_event(DeviceEvent event) {
  std::lock_guard lock(state_mutex_);
  if (events_.size() >= max_pending_events) {
    events_.erase(events_.begin());
    ++events_dropped_;
  }
  events_.push_back(std::move(event));
}

std::vector<DeviceEvent> Driver::take_events() {
  std::vector<DeviceEvent> out;
  std::uint64_t dropped = 0;
  {
    std::lock_guard lock(state_mutex_);
    out.swap(events_);
    dropped = std::exchange(events_dropped_, 0);
  }
  if (dropped > 0) {
    out.insert(out.begin(), DeviceEvent{"events_dropped", std::to_string(dropped) +
                                                              " older events of this device were dropped (more than " +
                                                              std::to_string(max_pending_events) + " waiting)"});
  }
  return out;
}

void Driver::publish(Sample sample) noexcept {
  sample.seq = next_seq_++;
  samples_.store(next_seq_, std::memory_order_relaxed);
  last_sample_ns_.store(sample.t_mono_ns, std::memory_order_relaxed);
  published_.store(published_.load(std::memory_order_relaxed) + 1, std::memory_order_release);
  ring_.try_push(sample);
  if (Doorbell* bell = doorbell_.load(std::memory_order_acquire)) bell->ring();
}

void Driver::skip_samples(std::uint64_t n) noexcept {
  next_seq_ += n;
  samples_.store(next_seq_, std::memory_order_relaxed);
}

bool Driver::sleep_for(const std::stop_token& stop, std::chrono::nanoseconds d) {
  std::mutex m;
  std::condition_variable_any cv;
  std::unique_lock lock(m);
  return !cv.wait_for(lock, stop, d, [] { return false; }) && !stop.stop_requested();
}

void DriverRegistry::add(std::string driver, std::string description, DriverFactory factory) {
  auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& e) { return e.driver == driver; });
  if (it != entries_.end()) {
    it->description = std::move(description);
    it->factory = std::move(factory);
    return;
  }
  entries_.push_back({std::move(driver), std::move(description), std::move(factory)});
}

bool DriverRegistry::contains(std::string_view driver) const {
  return std::any_of(entries_.begin(), entries_.end(), [&](const Entry& e) { return e.driver == driver; });
}

std::unique_ptr<Driver> DriverRegistry::create(const DeviceConfig& config) const {
  for (const Entry& e : entries_) {
    if (e.driver == config.driver) return e.factory(config);
  }
  std::string known;
  for (const Entry& e : entries_) known += (known.empty() ? "" : ", ") + e.driver;
  config.table.fail("driver", "unknown driver \"" + config.driver +
                                  "\" (known: " + (known.empty() ? std::string("none") : known) + ")");
}

std::vector<std::pair<std::string, std::string>> DriverRegistry::list() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const Entry& e : entries_) out.emplace_back(e.driver, e.description);
  return out;
}

}  // namespace guideway::drivers
