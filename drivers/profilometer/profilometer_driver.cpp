#include "drivers/profilometer/profilometer_driver.hpp"

#include <sys/epoll.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>

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
  c.read_period_us = t.get_int("read_period_us", drivers::default_read_period_us, 0, 100'000);
  if (c.read_period_us * 1000 >= c.stall_timeout.count() * 1'000'000)
    t.fail("read_period_us",
           "must be shorter than stall_timeout_ms (" + std::to_string(c.stall_timeout.count()) + " ms)");
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

void ProfilometerDriver::attach(drivers::IoLoop& loop) {
  io_ = &loop;
  assembler_ = ProfileAssembler{};
  events_.clear();
  events_.reserve(1024);
  buffer_.resize(16384);
  backoff_ = drivers::ReconnectBackoff(config_.backoff_initial, config_.backoff_max);
  ever_connected_ = false;
  timer_ = loop.add_timer([this] { on_timer(); });
  connector_.attach(
      loop, [this](int fd) { connected(fd); }, [this](const std::string& error) { connect_failed(error); });
  if (config_.read_period_us > 0) {
    wake_hook_ = loop.add_wake_hook([this] { on_wake(); });
    settle_hook_ = loop.add_settle_hook([this] { on_settle(); });
  }
  begin_connect();
}

void ProfilometerDriver::detach() {
  connector_.detach();
  if (link_ == Link::streaming) {
    close_socket();
    assembler_.finish(events_);  // what arrived before the stop is published, never dropped
    publish_events(events_);
  }
  close_socket();
  io_->remove_timer(timer_);
  if (wake_hook_ != 0) io_->remove_hook(wake_hook_);
  if (settle_hook_ != 0) io_->remove_hook(settle_hook_);
  wake_hook_ = settle_hook_ = 0;
  link_ = Link::waiting;
  io_ = nullptr;
}

void ProfilometerDriver::close_socket() {
  if (fd_ < 0) return;
  io_->unwatch(fd_);
  ::close(fd_);
  fd_ = -1;
}

void ProfilometerDriver::begin_connect() {
  set_state(drivers::DeviceState::connecting);
  link_ = Link::connecting;
  connector_.start(config_.host, config_.port, config_.host + ":" + std::to_string(config_.port),
                   config_.connect_timeout);
}

void ProfilometerDriver::connect_failed(const std::string& error) {
  set_state(drivers::DeviceState::lost, error);
  wait_backoff();
}

void ProfilometerDriver::wait_backoff() {
  link_ = Link::waiting;
  deadline_ns_ = mono_now_ns() + backoff_.take_ns();
  io_->arm(timer_, deadline_ns_);
}

void ProfilometerDriver::connected(int fd) {
  fd_ = fd;
  tcp::set_stream_options(fd_);
  if (ever_connected_) reconnects_.fetch_add(1, std::memory_order_relaxed);
  ever_connected_ = true;
  link_ = Link::streaming;
  set_state(drivers::DeviceState::streaming);
  const std::int64_t now = mono_now_ns();
  last_data_ns_ = now;
  last_read_ns_ = now;
  read_at_ns_ = now;  // wait for the first bytes
  resting_ = false;
  idle_check_ = false;
  lonely_ = false;
  others_pass_ = false;
  io_->watch(fd_, EPOLLIN, [this](std::uint32_t events) { on_ready(events); });
  io_->arm(timer_, last_data_ns_ + std::chrono::nanoseconds(config_.stall_timeout).count());
}

void ProfilometerDriver::on_ready(std::uint32_t) {
  if (link_ != Link::streaming) return;
  read_batch(false);  // bytes, or the end of the connection (hang-up, error): the read says which
}

void ProfilometerDriver::on_settle() {
  if (!idle_check_ || link_ != Link::streaming) return;
  idle_check_ = false;
  if (io_->data_found_this_pass()) return;  // others stream: read again at their next pass
  const std::int64_t now = mono_now_ns();
  read_at_ns_ = now;  // nothing anywhere: the next bytes wake us
  lonely_ = true;
  others_pass_ = false;
  arm_streaming_timer(now);
}

void ProfilometerDriver::on_wake() {
  if (link_ != Link::streaming || served_pass_ == io_->passes()) return;
  others_pass_ = true;  // a pass this driver did not cause: another device keeps the loop busy
  if (io_->now() < read_at_ns_) read_batch(true);
}

void ProfilometerDriver::on_timer() {
  const std::int64_t now = mono_now_ns();
  switch (link_) {
    case Link::connecting:
      return;  // the connector's own timer
    case Link::waiting:
      if (now < deadline_ns_) {
        io_->arm(timer_, deadline_ns_);
        return;
      }
      begin_connect();
      return;
    case Link::streaming:
      if (now >= read_at_ns_ && served_pass_ != io_->passes()) read_batch(false);
      if (link_ != Link::streaming) return;
      if (now - last_data_ns_ >= std::chrono::nanoseconds(config_.stall_timeout).count()) {
        timeouts_.fetch_add(1, std::memory_order_relaxed);
        end_connection("no data for " + std::to_string(config_.stall_timeout.count()) + " ms");
        return;
      }
      arm_streaming_timer(mono_now_ns());
      break;
  }
}

void ProfilometerDriver::arm_streaming_timer(std::int64_t now) {
  const bool resting = now < read_at_ns_;
  resting_ = resting;
  io_->modify(fd_, resting ? 0u : std::uint32_t{EPOLLIN});
  const std::int64_t stall_at = last_data_ns_ + std::chrono::nanoseconds(config_.stall_timeout).count();
  io_->arm(timer_, resting ? std::min(read_at_ns_, stall_at) : stall_at);
}

void ProfilometerDriver::read_batch(bool opportunistic) {
  served_pass_ = io_->passes();
  std::size_t taken = 0;
  bool more = false;
  std::string ended;
  for (;;) {
    if (taken >= max_read_bytes) {  // a flooding instrument: the other devices first, then on
      more = true;
      break;
    }
    const tcp::ReadResult r = tcp::read_some(fd_, buffer_.data(), buffer_.size());
    if (r.status == tcp::ReadStatus::would_block) break;
    if (r.status != tcp::ReadStatus::data) {
      ended = r.message;
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
    taken += r.bytes;
    assembler_.feed(std::string_view(buffer_.data(), r.bytes), t, events_);
    for (const StreamEvent& e : events_) {
      if (e.type == StreamEvent::Type::header) {
        std::lock_guard lock(header_mutex_);
        last_header_ = assembler_.header();
      }
    }
    publish_events(events_);
    backoff_.reset();
    if (r.bytes < buffer_.size()) break;  // the socket is empty (or nearly: the next pass takes the rest)
  }
  const std::int64_t now = mono_now_ns();
  last_read_ns_ = now;
  if (!ended.empty()) {
    end_connection(ended);
    return;
  }
  if (taken > 0) {
    io_->data_found();
    last_data_ns_ = now;
    // Points flow: rest a period while the next ones queue up (at once after a flood's partial read).
    // Alone on the loop with bytes further apart than a period, a rest would only add a wake-up that
    // finds nothing: after such a rest (lonely_) the driver wakes per arrival until another device
    // makes the loop pass by.
    if (others_pass_) lonely_ = false;
    others_pass_ = false;
    read_at_ns_ = more || lonely_ || config_.read_period_us == 0 ? now : now + config_.read_period_us * 1000;
    if (more) io_->again();
  } else {
    // Nothing came. Read at another device's pass, or at the end of a rest: rest on (the end of a rest
    // is settled once the pass has read every device: on_settle). After readiness: the next bytes wake us.
    if (opportunistic || resting_) read_at_ns_ = now + config_.read_period_us * 1000;
    idle_check_ = !opportunistic && resting_;
  }
  arm_streaming_timer(now);
}

void ProfilometerDriver::end_connection(const std::string& reason) {
  close_socket();
  assembler_.finish(events_);  // what arrived before the fault is published, never dropped
  publish_events(events_);
  set_state(drivers::DeviceState::lost, reason);
  wait_backoff();
}

void register_profilometer_driver(drivers::DriverRegistry& registry) {
  registry.add("profilometer-tcp", "profilometer (PGI 1240-style) profile stream over TCP",
               [](const drivers::DeviceConfig& c) -> std::unique_ptr<drivers::Driver> {
                 return std::make_unique<ProfilometerDriver>(c.name, parse_profilometer_config(c.table),
                                                             c.ring_capacity);
               });
}

}  // namespace guideway::drivers::profilometer
