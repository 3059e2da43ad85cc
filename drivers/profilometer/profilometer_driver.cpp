// "profilometer-tcp" (profilometer_driver.hpp): a profilometer's stream over TCP, one sample per point, traverses
// assembled.
#include "drivers/profilometer/profilometer_driver.hpp"

#include <algorithm>
#include <cstring>

#include "core/mono_clock.hpp"
#include "drivers/tcp/tcp_client.hpp"

namespace guideway::drivers::profilometer {

ProfilometerConfig parse_profilometer_config(const TableReader& t) {
  ProfilometerConfig c;
  c.host = t.get_string("host", "127.0.0.1");
  if (c.host.empty()) t.fail("host", "must not be empty");
  c.port = static_cast<int>(t.require_int("port", 1, 65535));
  c.connect_timeout = std::chrono::milliseconds(t.get_int("connect_timeout_ms", 1000, 1, 600000));
  c.stall_timeout = std::chrono::milliseconds(t.get_int("stall_timeout_ms", 2000, 10, 3600000));
  c.reconnect = drivers::read_reconnect(t, std::chrono::milliseconds(100), std::chrono::milliseconds(5000));
  c.read_period_us = t.get_int("read_period_us", drivers::default_read_period_us, 0, 100'000);
  c.points_per_s = t.get_double("points_per_s", c.points_per_s, 1.0, 1e6);
  if (c.read_period_us * 1000 >= c.stall_timeout.count() * 1'000'000)
    t.fail("read_period_us",
           "must be shorter than stall_timeout_ms (" + std::to_string(c.stall_timeout.count()) + " ms)");
  return c;
}

namespace {

drivers::LoopPolicy policy_of(const ProfilometerConfig& c) {
  drivers::LoopPolicy p;
  p.reconnect = c.reconnect;
  p.schedule = c.read_period_us > 0 ? drivers::ReadSchedule::rest : drivers::ReadSchedule::per_arrival;
  p.read_period_ns = c.read_period_us * 1000;
  p.silence_ns = std::chrono::nanoseconds(c.stall_timeout).count();  // the link is lost
  p.sample_bound_ns = p.silence_ns;  // points flow while a traverse is measured, headers between them
  return p;
}

}  // namespace

ProfilometerDriver::ProfilometerDriver(std::string name, ProfilometerConfig config, std::size_t ring_capacity)
    : LoopDriver(std::move(name), "profilometer-tcp", {{"x", "m"}, {"z", "m"}, {"profile", "1"}, {"index", "1"}},
                 ring_capacity, policy_of(config)),
      config_(std::move(config)) {
  events_.reserve(1024);
}

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

void ProfilometerDriver::open() {
  connect_tcp(config_.host, config_.port, config_.host + ":" + std::to_string(config_.port), config_.connect_timeout);
}

void ProfilometerDriver::on_link_up(std::int64_t now_ns) { last_read_ns_ = now_ns; }

void ProfilometerDriver::on_link_down() {
  assembler_.finish(events_);  // what arrived before the fault or the stop is published, never dropped
  publish_events(events_);
}

drivers::ReadOutcome ProfilometerDriver::read_some(bool) {
  drivers::ReadOutcome out;
  const std::int64_t newest_before = last_t_ns_;
  for (;;) {
    if (out.taken >= max_read_bytes) {  // a flooding instrument: the other devices first, then on
      out.more = true;
      break;
    }
    const tcp::ReadResult r = tcp::read_some(link_fd(), buffer_.data(), buffer_.size());
    if (r.status == tcp::ReadStatus::would_block) break;
    if (r.status != tcp::ReadStatus::data) {
      out.ended = r.message;
      break;
    }
    const std::int64_t read_ns = mono_now_ns();
    // The bytes' time: when the kernel received the newest segment of them (a read's bytes may span
    // several segments: the earlier ones are late by at most the read period), on the monotonic
    // clock; the read's time when there is none or it is implausible (a step of the real-time clock).
    std::int64_t t = read_ns;
    if (r.rx_realtime_ns != tcp::no_rx_timestamp) {
      const std::int64_t k = r.rx_realtime_ns - realtime_minus_mono_ns();
      if (k <= read_ns + 1'000'000 && k >= last_read_ns_ - 1'000'000) t = std::min(k, read_ns);
    }
    t = std::max(t, last_t_ns_);
    last_t_ns_ = t;
    out.taken += r.bytes;
    assembler_.feed(std::string_view(buffer_.data(), r.bytes), t, events_);
    for (const StreamEvent& e : events_) {
      if (e.type == StreamEvent::Type::header) {
        std::lock_guard lock(header_mutex_);
        last_header_ = assembler_.header();
      }
    }
    publish_events(events_);
    if (r.bytes < buffer_.size()) break;  // the socket is empty (or nearly: the next pass takes the rest)
  }
  last_read_ns_ = mono_now_ns();
  if (out.taken > 0) arrival_gap_ns_ = last_t_ns_ - newest_before;
  return out;
}

bool ProfilometerDriver::rest_after(const drivers::ReadOutcome&) const {
  return arrival_gap_ns_ < 2 * policy().read_period_ns;
}

void register_profilometer_driver(drivers::DriverRegistry& registry) {
  registry.add("profilometer-tcp", "profilometer (PGI 1240-style) profile stream over TCP",
               [](const drivers::DeviceConfig& c) -> std::unique_ptr<drivers::Driver> {
                 ProfilometerConfig p = parse_profilometer_config(c.table);
                 const std::size_t ring = c.ring_for(p.points_per_s);
                 return std::make_unique<ProfilometerDriver>(c.name, std::move(p), ring);
               });
}

}  // namespace guideway::drivers::profilometer
