#include "drivers/profilometer/profilometer_driver.hpp"

#include <algorithm>
#include <array>

#include "core/mono_clock.hpp"

namespace guideway::drivers::profilometer {

ProfilometerConfig parse_profilometer_config(const TableReader& t) {
  ProfilometerConfig c;
  c.host = t.get_string("host", "127.0.0.1");
  if (c.host.empty()) t.fail("host", "must not be empty");
  c.port = static_cast<int>(t.require_int("port", 1, 65535));
  c.connect_timeout = std::chrono::milliseconds(t.get_int("connect_timeout_ms", 1000, 1, 600000));
  c.stall_timeout = std::chrono::milliseconds(t.get_int("stall_timeout_ms", 2000, 10, 3600000));
  c.backoff_initial = std::chrono::milliseconds(t.get_int("backoff_initial_ms", 100, 1, 600000));
  c.backoff_max = std::chrono::milliseconds(t.get_int("backoff_max_ms", 5000, 1, 3600000));
  if (c.backoff_max < c.backoff_initial) t.fail("backoff_max_ms", "must not be less than backoff_initial_ms");
  return c;
}

ProfilometerDriver::ProfilometerDriver(std::string name, ProfilometerConfig config, std::size_t ring_capacity)
    : Driver(std::move(name), "profilometer-tcp", {{"x", "m"}, {"z", "m"}, {"profile", "1"}, {"index", "1"}},
             ring_capacity),
      config_(std::move(config)) {}

ProfilometerDriver::~ProfilometerDriver() { stop(); }

std::optional<ProfileHeader> ProfilometerDriver::last_header() const {
  std::lock_guard lock(header_mutex_);
  return last_header_;
}

void ProfilometerDriver::publish_events(std::vector<StreamEvent>& events) {
  for (const StreamEvent& e : events) {
    switch (e.type) {
      case StreamEvent::Type::point: {
        Sample s;
        s.t_mono_ns = e.t_ns;
        s.flags = e.flags;
        s.value_count = 4;
        s.value[0] = e.x_m;
        s.value[1] = e.z_m;
        s.value[2] = static_cast<double>(e.profile_id);
        s.value[3] = static_cast<double>(e.index);
        publish(s);
        frames_.fetch_add(1, std::memory_order_relaxed);
        break;
      }
      case StreamEvent::Type::bad_line:
        bad_frames_.fetch_add(1, std::memory_order_relaxed);
        break;
      case StreamEvent::Type::end:
        profiles_.fetch_add(1, std::memory_order_relaxed);
        if (e.points_lost > 0) {
          profiles_partial_.fetch_add(1, std::memory_order_relaxed);
          points_lost_.fetch_add(e.points_lost, std::memory_order_relaxed);
        }
        frames_.fetch_add(1, std::memory_order_relaxed);
        break;
      case StreamEvent::Type::header:
        frames_.fetch_add(1, std::memory_order_relaxed);
        break;
      case StreamEvent::Type::banner:
        frames_.fetch_add(1, std::memory_order_relaxed);
        break;
    }
  }
  events.clear();
}

void ProfilometerDriver::run(std::stop_token stop) {
  client_.clear_interrupt();  // left set by a previous stop(): this run starts afresh
  ProfileAssembler assembler;
  std::vector<StreamEvent> events;
  events.reserve(1024);
  std::array<char, 16384> buffer{};
  auto backoff = config_.backoff_initial;
  bool ever_connected = false;
  while (!stop.stop_requested()) {
    set_state(drivers::DeviceState::connecting);
    std::string error;
    if (!client_.connect(config_.host, config_.port, config_.connect_timeout, error)) {
      if (stop.stop_requested()) break;
      set_state(drivers::DeviceState::lost, error);
      if (!sleep_for(stop, backoff)) break;
      backoff = std::min(backoff * 2, config_.backoff_max);
      continue;
    }
    if (ever_connected) reconnects_.fetch_add(1, std::memory_order_relaxed);
    ever_connected = true;
    set_state(drivers::DeviceState::streaming);
    std::string reason;
    while (!stop.stop_requested()) {
      const tcp::ReadResult r = client_.read_some(buffer.data(), buffer.size(), config_.stall_timeout);
      if (r.status == tcp::ReadStatus::data) {
        assembler.feed(std::string_view(buffer.data(), r.bytes), mono_now_ns(), events);
        for (const StreamEvent& e : events) {
          if (e.type == StreamEvent::Type::header) {
            std::lock_guard lock(header_mutex_);
            last_header_ = assembler.header();
          }
        }
        publish_events(events);
        backoff = config_.backoff_initial;
        continue;
      }
      if (r.status == tcp::ReadStatus::interrupted) break;
      if (r.status == tcp::ReadStatus::timeout) {
        timeouts_.fetch_add(1, std::memory_order_relaxed);
        reason = "no data for " + std::to_string(config_.stall_timeout.count()) + " ms";
      } else {
        reason = r.message;
      }
      break;
    }
    client_.close();
    assembler.finish(events);  // what arrived before the fault is published, never dropped
    publish_events(events);
    if (stop.stop_requested()) break;
    set_state(drivers::DeviceState::lost, reason);
    if (!sleep_for(stop, backoff)) break;
    backoff = std::min(backoff * 2, config_.backoff_max);
  }
}

void register_profilometer_driver(drivers::DriverRegistry& registry) {
  registry.add("profilometer-tcp", "profilometer (PGI 1240-style) profile stream over TCP",
               [](const drivers::DeviceConfig& c) -> std::unique_ptr<drivers::Driver> {
                 return std::make_unique<ProfilometerDriver>(c.name, parse_profilometer_config(c.table),
                                                             c.ring_capacity);
               });
}

}  // namespace guideway::drivers::profilometer
