#include "drivers/dbb/dbb_driver.hpp"

#include <linux/can/error.h>
#include <sys/epoll.h>
#include <sys/socket.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "core/mono_clock.hpp"

namespace guideway::drivers::dbb {

namespace {

// An operational node is silent after the device's own silence timeout without its PDO.
DbbSettings with_pdo_timeout(DbbSettings s) {
  s.network.pdo_timeout_ms = s.timeout_ms;
  return s;
}

std::vector<drivers::ChannelInfo> channels_of(const DbbSettings& s) {
  std::vector<drivers::ChannelInfo> out;
  for (const auto& e : s.encoders) out.push_back({e.channel, "m"});
  return out;
}

// The serial as a number (decimal, or hexadecimal after 0x): what a CANopen node's 0x1018:4 can be.
std::optional<std::uint32_t> serial_number_of(const std::string& serial) {
  const bool hex = serial.size() > 2 && serial[0] == '0' && (serial[1] == 'x' || serial[1] == 'X');
  const std::string digits = hex ? serial.substr(2) : serial;
  if (digits.empty() || digits.size() > 10) return std::nullopt;
  std::uint64_t v = 0;
  for (const char c : digits) {
    const int d = c >= '0' && c <= '9'          ? c - '0'
                  : hex && c >= 'a' && c <= 'f' ? c - 'a' + 10
                  : hex && c >= 'A' && c <= 'F' ? c - 'A' + 10
                                                : -1;
    if (d < 0) return std::nullopt;
    v = v * (hex ? 16 : 10) + static_cast<std::uint64_t>(d);
  }
  if (v > 0xFFFFFFFFu) return std::nullopt;
  return static_cast<std::uint32_t>(v);
}

// The instrument keys of the [[device]] table (the daemon reads and checks them; docs/configuration.md)
// that concern the bus: the ballbar is its length encoder (channel bar_length, else the first encoder),
// whose serial number must be the instrument's `serial`, and whose reading at zero_count is the bar's
// calibrated length.
void apply_instrument_keys(const TableReader& t, DbbSettings& s) {
  std::size_t bar = 0;
  for (std::size_t i = 0; i < s.encoders.size(); ++i)
    if (s.encoders[i].channel == "bar_length") bar = i;
  if (const auto serial = serial_number_of(t.get_string("serial", ""))) s.nodes[bar].instrument_serial = serial;
  if (!t.has("calibrated_length_mm")) return;
  const double length_mm = t.get_double("calibrated_length_mm", 0.0);
  EncoderScale& e = s.encoders[bar];
  const auto encoder_tables = t.tables("encoder");
  if (!encoder_tables[bar].has("offset_mm")) {
    e.offset_m = length_mm * 1e-3;
  } else if (std::abs(e.offset_m * 1e3 - length_mm) > 1e-7) {
    char buf[200];
    std::snprintf(
        buf, sizeof buf,
        "%.10g mm differs from the bar's calibrated_length_mm = %.10g mm: the bar reads its calibrated length "
        "at zero_count (leave offset_mm out to take it from calibrated_length_mm)",
        e.offset_m * 1e3, length_mm);
    encoder_tables[bar].fail("offset_mm", buf);
  }
}

}  // namespace

DbbSettings parse_dbb_settings(const TableReader& t) {
  DbbSettings s;
  const std::string endpoint = t.require_string("bus");
  std::string err;
  if (!parse_can_endpoint(endpoint, s.endpoint, err)) t.fail("bus", err);
  s.produce_sync = t.get_choice("sync", "produce", {"produce", "listen"}) == "produce";
  s.sync_rate_hz = t.get_double("sync_rate_hz", 100.0, 0.1, 10000.0);
  s.timeout_ms = t.get_int("timeout_ms", 500, 1, 600000);
  if (s.produce_sync && t.has("read_period_us")) {
    t.fail("read_period_us", "applies to sync = \"listen\" only (a SYNC producer reads at its own SYNCs)");
  }
  s.read_period_us = t.get_int("read_period_us", default_read_period_us, 0, 100'000);
  if (s.read_period_us * 1000 >= s.timeout_ms * 1'000'000) {
    t.fail("read_period_us", "must be shorter than timeout_ms (" + std::to_string(s.timeout_ms) + " ms)");
  }
  s.reconnect_min_ms = t.get_int("reconnect_min_ms", 50, 1, 600000);
  s.reconnect_max_ms = t.get_int("reconnect_max_ms", 5000, s.reconnect_min_ms, 3600000);
  NetworkSettings& n = s.network;
  n.manage_nmt = t.get_choice("nmt", "start", {"start", "listen"}) == "start";
  n.sdo_checks = t.get_bool("sdo_checks", n.manage_nmt);
  n.configure_nodes = t.get_bool("configure_nodes", false);
  if (n.configure_nodes && !n.sdo_checks)
    t.fail("configure_nodes", "needs sdo_checks = true (it writes what the checks read)");
  n.heartbeat_ms = t.get_int("heartbeat_ms", 0, 0, 65535);
  const std::int64_t heartbeat_timeout_ms = t.get_int("heartbeat_timeout_ms", 3 * n.heartbeat_ms, 0, 600000);
  if (t.has("heartbeat_timeout_ms") && heartbeat_timeout_ms <= n.heartbeat_ms && heartbeat_timeout_ms != 0) {
    t.fail("heartbeat_timeout_ms", "must be longer than heartbeat_ms (" + std::to_string(n.heartbeat_ms) + " ms)");
  }
  n.sdo_timeout_ms = t.get_int("sdo_timeout_ms", 100, 1, 10000);
  n.node_retry_ms = t.get_int("node_retry_ms", 2000, 10, 600000);
  constexpr std::int64_t u32_max = 0xFFFFFFFF;
  const auto optional_u32 = [](const TableReader& e, const char* key) -> std::optional<std::uint32_t> {
    if (!e.has(key)) return std::nullopt;
    return static_cast<std::uint32_t>(e.get_int(key, 0, 0, u32_max));
  };
  for (const TableReader& e : t.tables("encoder")) {
    EncoderScale sc;
    sc.channel = e.require_string("channel");
    sc.node_id = static_cast<std::uint8_t>(e.require_int("node_id", 1, 127));
    sc.resolution_m = e.require_double("resolution_nm", 1e-6, 1e9) * 1e-9;
    sc.direction = e.get_choice("direction", "positive", {"positive", "negative"}) == "positive" ? 1 : -1;
    sc.zero_count = e.get_int("zero_count", 0, -(std::int64_t{1} << 40), std::int64_t{1} << 40);
    sc.offset_m = e.get_double("offset_mm", 0.0, -1e6, 1e6) * 1e-3;
    NodeExpectation x;
    x.vendor_id = optional_u32(e, "vendor_id");
    x.product_code = optional_u32(e, "product_code");
    x.revision_number = optional_u32(e, "revision_number");
    x.serial_number = optional_u32(e, "serial_number");
    x.check_resolution = e.get_bool("check_resolution", true);
    x.heartbeat_timeout_ms = e.get_int("heartbeat_timeout_ms", heartbeat_timeout_ms, 0, 600000);
    if (e.has("heartbeat_timeout_ms") && x.heartbeat_timeout_ms != 0 && x.heartbeat_timeout_ms <= n.heartbeat_ms) {
      e.fail("heartbeat_timeout_ms", "must be longer than heartbeat_ms (" + std::to_string(n.heartbeat_ms) + " ms)");
    }
    s.nodes.push_back(x);
    for (const auto& other : s.encoders) {
      if (other.node_id == sc.node_id) e.fail("node_id", "node " + std::to_string(sc.node_id) + " is used twice");
      if (other.channel == sc.channel) e.fail("channel", "channel \"" + sc.channel + "\" is used twice");
    }
    e.reject_unknown_keys();
    s.encoders.push_back(std::move(sc));
  }
  if (s.encoders.empty()) t.fail("encoder", "at least one [[device.encoder]] table is required");
  apply_instrument_keys(t, s);
  if (s.encoders.size() > max_encoders) {
    t.fail("encoder", "at most " + std::to_string(max_encoders) + " encoders per bus");
  }
  return s;
}

FrameTime frame_time(std::int64_t rx_realtime_ns, std::int64_t realtime_offset_ns, std::int64_t earliest_ns,
                     std::int64_t read_ns) noexcept {
  // The kernel stamps a frame just before queuing it; 1 ms of slack covers a sender descheduled
  // between the two and the conversion's own jitter.
  constexpr std::int64_t slack_ns = 1'000'000;
  if (rx_realtime_ns == can::no_rx_timestamp) return {read_ns, false};
  const std::int64_t t = rx_realtime_ns - realtime_offset_ns;
  if (t < earliest_ns - slack_ns || t > read_ns + slack_ns) return {read_ns, false};
  return {std::min(t, read_ns), true};
}

std::vector<can_filter> dbb_can_filters(const DbbSettings& settings) {
  // Exact standard identifier; a remote request or an extended frame with the same bits does not match.
  constexpr canid_t exact = CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG;
  std::vector<can_filter> out{{sync_cob_id, exact}};
  for (const auto& e : settings.encoders) {
    for (const std::uint32_t base : {tpdo1_cob_base, can::emcy_cob_base, can::tsdo_cob_base, can::heartbeat_cob_base})
      out.push_back({base + e.node_id, exact});
  }
  return out;
}

void order_frame_times(std::span<FrameTime> times, std::int64_t& last_ns) noexcept {
  std::int64_t next_kernel_ns = INT64_MAX;  // the kernel time of the next frame that has one
  for (std::size_t i = times.size(); i-- > 0;) {
    if (times[i].from_kernel) {
      next_kernel_ns = times[i].t_ns;
    } else {
      times[i].t_ns = std::min(times[i].t_ns, next_kernel_ns);
    }
  }
  for (FrameTime& t : times) {
    t.t_ns = std::max(t.t_ns, last_ns);
    last_ns = t.t_ns;
  }
}

DbbDriver::DbbDriver(std::string name, std::size_t ring_capacity, DbbSettings settings, CanConnector connector)
    : Driver(std::move(name), "dbb-can", channels_of(settings), ring_capacity),
      settings_(with_pdo_timeout(std::move(settings))),
      connector_(std::move(connector)),
      network_(settings_.encoders, settings_.nodes, settings_.network) {
  if (!connector_) {
    // Foreign traffic on a shared bus is filtered out in the kernel, so it never wakes the driver.
    connector_ = [endpoint = settings_.endpoint, filters = dbb_can_filters(settings_)](std::string& error) {
      return can::open_can_endpoint(endpoint, error, filters);
    };
  }
}

DbbDriver::~DbbDriver() { stop(); }

std::vector<drivers::NamedCounter> DbbDriver::driver_counters() const {
  return {{"error_frames", error_frames()},
          {"bus_off", bus_offs_.load(std::memory_order_relaxed)},
          {"partial_cycles", partial_cycles()},
          {"late_pdos", late_pdos_.load(std::memory_order_relaxed)},
          {"syncs_not_sent", syncs_not_sent_.load(std::memory_order_relaxed)},
          {"untimed_frames", untimed_frames()},
          {"dropped_frames", dropped_frames()},
          {"frames_not_sent", frames_not_sent_.load(std::memory_order_relaxed)},
          {"node_boot_ups", boot_ups_.load(std::memory_order_relaxed)},
          {"heartbeat_timeouts", heartbeat_timeouts_.load(std::memory_order_relaxed)},
          {"emcy", emcys_.load(std::memory_order_relaxed)},
          {"sdo_aborts", sdo_aborts_.load(std::memory_order_relaxed)},
          {"sdo_timeouts", sdo_timeouts_.load(std::memory_order_relaxed)},
          {"nmt_starts", nmt_starts_.load(std::memory_order_relaxed)}};
}

void DbbDriver::set_state_directly(drivers::DeviceState state, std::string reason) {
  set_state(state, std::move(reason));
  shown_state_ = drivers::DeviceState::stopped;  // whatever refresh_state finds next differs
  shown_reason_.clear();
  state_dirty_ = true;
}

void DbbDriver::refresh_state() {
  if (!state_dirty_ && network_.health_version() == state_network_version_) return;
  state_dirty_ = false;
  state_network_version_ = network_.health_version();
  set_warnings(network_.warnings());
  const NetworkHealth& h = network_.health();
  drivers::DeviceState state = drivers::DeviceState::streaming;
  std::string why;
  const std::string silence = "no frames for " + std::to_string(settings_.timeout_ms) + " ms";
  // The nodes' own story comes first where it explains a silence (refused or not yet started nodes send nothing).
  if (bus_off_since_ns_ != 0) {
    state = drivers::DeviceState::error;
    why = "CAN bus off";
  } else if (h.level == NetworkHealth::Level::failed || h.level == NetworkHealth::Level::starting) {
    state = h.level == NetworkHealth::Level::failed ? drivers::DeviceState::error : drivers::DeviceState::connecting;
    why = h.reason + (silent_ ? "; " + silence : "");
  } else if (silent_) {
    state = drivers::DeviceState::lost;
    why = silence + (h.level == NetworkHealth::Level::lost ? "; " + h.reason : "");
  } else if (h.level == NetworkHealth::Level::lost) {
    state = drivers::DeviceState::lost;
    why = h.reason;
  } else if (!complete_cycle_seen_) {
    state = drivers::DeviceState::connecting;
    why = "waiting for the first complete cycle";
  } else {
    why = note_;
  }
  if (state != drivers::DeviceState::streaming) note_.clear();
  if (state == shown_state_ && why == shown_reason_) return;
  shown_state_ = state;
  shown_reason_ = why;
  set_state(state, std::move(why));
}

void DbbDriver::service_network(std::int64_t now) {
  network_.tick(now);
  std::string error;
  for (const can_frame& f : network_.outgoing()) {
    // Never wait for the bus: a refused frame is counted; SDO requests and NMT starts are repeated on timeout.
    if (can::try_write_can_frame(sock_.fd(), f, error) != can::WriteResult::written)
      frames_not_sent_.fetch_add(1, std::memory_order_relaxed);
  }
  network_.outgoing().clear();
  for (NetworkEvent& e : network_.events()) post_event({std::move(e.event), std::move(e.reason), e.warning});
  network_.events().clear();
  const NetworkCounters& c = network_.counters();
  boot_ups_.store(c.boot_ups, std::memory_order_relaxed);
  heartbeat_timeouts_.store(c.heartbeat_timeouts, std::memory_order_relaxed);
  emcys_.store(c.emcys, std::memory_order_relaxed);
  sdo_aborts_.store(c.sdo_aborts, std::memory_order_relaxed);
  sdo_timeouts_.store(c.sdo_timeouts, std::memory_order_relaxed);
  nmt_starts_.store(c.nmt_starts, std::memory_order_relaxed);
  refresh_state();
}

void DbbDriver::publish_cycle(const DbbCycle& c) {
  network_.on_cycle(c.present, c.t_sync_ns);
  Sample s;
  s.t_mono_ns = c.t_sync_ns;
  s.flags = c.flags;
  if (network_.take_gap()) s.flags |= sample_after_gap;  // a node's first PDO after its reboot or silence
  s.value_count = static_cast<std::uint32_t>(c.count);
  std::copy_n(c.position_m.begin(), c.count, s.value.begin());
  if (c.flags & sample_partial) partial_cycles_.fetch_add(1, std::memory_order_relaxed);
  publish(s);
  // A cycle after a silence or a bus-off: streaming again (if the nodes are all there).
  const std::int64_t t_ns = c.t_sync_ns;
  if (!complete_cycle_seen_ && !(c.flags & sample_partial)) {
    complete_cycle_seen_ = true;
    state_dirty_ = true;
  }
  if (bus_off_since_ns_ != 0 && t_ns - bus_off_since_ns_ >= 1'000'000'000) {
    note_ = "CAN frames flow again " + std::to_string((t_ns - bus_off_since_ns_) / 1'000'000) +
            " ms after bus-off (no restart notice)";
    bus_off_since_ns_ = 0;
    silent_ = false;
    state_dirty_ = true;
  } else if (silent_ && bus_off_since_ns_ == 0) {
    silent_ = false;
    state_dirty_ = true;
  }
}

std::size_t DbbDriver::drain(std::string& ended, bool& more) {
  std::array<can_frame, 32> frames{};
  std::array<std::int64_t, 32> rx_realtime_ns{};
  std::string error;
  std::size_t records = 0;
  more = false;
  bus_reads_.fetch_add(1, std::memory_order_relaxed);
  for (;;) {
    if (records >= max_drain_frames) {  // a flooding bus: the other devices first, then on
      more = true;
      return records;
    }
    const std::int64_t read_start = mono_now_ns();
    can::FrameBatch batch;
    const can::ReadResult r = can::read_can_frames(sock_.fd(), frames, rx_realtime_ns, batch, error);
    if (r == can::ReadResult::closed) ended = "connection closed by the bus";
    if (r == can::ReadResult::error) ended = error;
    if (r != can::ReadResult::frame) {
      prev_read_ns_ = read_start;
      if (records == 0) empty_reads_.fetch_add(1, std::memory_order_relaxed);
      return records;
    }
    const std::int64_t read_ns = mono_now_ns();
    const std::int64_t offset_ns = realtime_minus_mono_ns();
    records += batch.count + batch.truncated;
    bad_frames_.fetch_add(batch.truncated, std::memory_order_relaxed);
    if (batch.kernel_drops > kernel_drops_) {  // a total for the socket: count what is new
      const std::uint32_t dropped = batch.kernel_drops - kernel_drops_;
      kernel_drops_ = batch.kernel_drops;
      dropped_frames_.fetch_add(dropped, std::memory_order_relaxed);
      bad_frames_.fetch_add(dropped, std::memory_order_relaxed);
    }
    std::array<FrameTime, frames.size()> times{};
    for (std::size_t i = 0; i < batch.count; ++i) {
      times[i] = frame_time(rx_realtime_ns[i], offset_ns, prev_read_ns_, read_ns);
      if (!times[i].from_kernel) untimed_frames_.fetch_add(1, std::memory_order_relaxed);
    }
    order_frame_times(std::span(times.data(), batch.count), last_frame_ns_);
    for (std::size_t i = 0; i < batch.count; ++i) handle_frame(frames[i], times[i].t_ns);
    if (batch.count + batch.truncated < frames.size()) {  // the queue is empty
      prev_read_ns_ = read_start;
      return records;
    }
  }
}

void DbbDriver::handle_frame(const can_frame& f, std::int64_t t_ns) {
  frames_.fetch_add(1, std::memory_order_relaxed);
  DbbCycle cycle;
  const auto res = decoder_->feed(f, t_ns, cycle);
  late_pdos_.store(decoder_->late_pdos(), std::memory_order_relaxed);
  if (res.info.kind == FrameInfo::Kind::bad) bad_frames_.fetch_add(1, std::memory_order_relaxed);
  if ((res.info.kind == FrameInfo::Kind::other || res.info.kind == FrameInfo::Kind::emergency) &&
      network_.on_frame(f, t_ns) == EncoderNetwork::FrameUse::bad) {
    bad_frames_.fetch_add(1, std::memory_order_relaxed);
  }
  if (res.info.kind == FrameInfo::Kind::sync) {
    if (last_sync_ns_ != 0) sync_period_ns_ = t_ns - last_sync_ns_;
    last_sync_ns_ = t_ns;
  }
  if (res.info.kind == FrameInfo::Kind::error_frame) {
    // A controller's restart notice is news, not an error on the bus.
    if ((res.info.error_class & ~static_cast<std::uint32_t>(CAN_ERR_RESTARTED)) != 0) {
      error_frames_.fetch_add(1, std::memory_order_relaxed);
      bad_frames_.fetch_add(1, std::memory_order_relaxed);
    }
    // Bus-off latches the error state until the controller says it restarted (or, without that
    // notice, frames have flowed again for a second): cleared by the next cycle, it lasted ~4 ms and
    // nobody saw it.
    if (res.info.error_class & CAN_ERR_BUSOFF) {
      bus_offs_.fetch_add(1, std::memory_order_relaxed);
      bus_off_since_ns_ = t_ns;
      silent_ = true;
      state_dirty_ = true;
      refresh_state();  // at once: the daemon polls states, the bus may come back before the next batch ends
    } else if ((res.info.error_class & CAN_ERR_RESTARTED) && bus_off_since_ns_ != 0) {
      note_ = "CAN bus recovered from bus-off after " + std::to_string((t_ns - bus_off_since_ns_) / 1'000'000) +
              " ms (controller restarted)";
      bus_off_since_ns_ = 0;
      silent_ = false;
      state_dirty_ = true;
    }
  }
  if (res.cycle_ready) publish_cycle(cycle);
}

void DbbDriver::note_silence(std::int64_t now) {
  timeouts_.fetch_add(1, std::memory_order_relaxed);
  // A bus that is off is silent: its state stays the error that says why (refresh_state).
  silent_ = true;
  state_dirty_ = true;
  last_rx_ns_ = now;     // count one timeout per silent period
  decoder_->mark_gap();  // what comes next follows a gap
}

void DbbDriver::attach(drivers::IoLoop& loop) {
  io_ = &loop;
  decoder_.emplace(settings_.encoders, settings_.produce_sync);
  backoff_ = drivers::ReconnectBackoff(std::chrono::milliseconds(settings_.reconnect_min_ms),
                                       std::chrono::milliseconds(settings_.reconnect_max_ms));
  connected_once_ = false;
  timer_ = loop.add_timer([this] { on_timer(); });
  if (batched()) {
    wake_hook_ = loop.add_wake_hook([this] { on_wake(); });
    settle_hook_ = loop.add_settle_hook([this] { on_settle(); });
  }
  connect();
}

void DbbDriver::detach() {
  if (sock_.valid()) {
    io_->unwatch(sock_.fd());
    sock_.reset();
    DbbCycle rest;
    if (decoder_->flush(rest)) publish_cycle(rest);  // nothing received is lost
  }
  io_->remove_timer(timer_);
  if (wake_hook_ != 0) io_->remove_hook(wake_hook_);
  if (settle_hook_ != 0) io_->remove_hook(settle_hook_);
  wake_hook_ = settle_hook_ = 0;
  io_ = nullptr;
}

void DbbDriver::connect() {
  std::string error;
  prev_read_ns_ = mono_now_ns();  // no frame on this connection was received before it was opened
  kernel_drops_ = 0;
  can::CanSocket sock = connector_(error);
  if (!sock.valid()) {
    set_state_directly(connected_once_ ? drivers::DeviceState::lost : drivers::DeviceState::error,
                       to_string(settings_.endpoint) + ": " + error);
    reconnect_at_ns_ = mono_now_ns() + backoff_.take_ns();
    io_->arm(timer_, reconnect_at_ns_);
    return;
  }
  if (connected_once_) reconnects_.fetch_add(1, std::memory_order_relaxed);
  connected_once_ = true;
  backoff_.reset();
  // Nothing is known of the nodes on a new connection: checked and started again, streaming again
  // from the first complete cycle.
  network_.connected(mono_now_ns());
  complete_cycle_seen_ = false;
  note_.clear();
  bus_off_since_ns_ = 0;
  state_dirty_ = true;
  silent_ = false;
  last_sync_ns_ = 0;
  sync_period_ns_ = 0;
  drain_pending_ = false;
  resting_ = false;
  idle_check_ = false;
  // Kernel receive times for every frame (SocketCAN and AF_UNIX sockets support them). The standard
  // endpoints enable them before bind/connect (else frames queued meanwhile would be stamped at the
  // read); this covers other connectors. Should a socket refuse, frames get the time they are read,
  // counted in untimed_frames.
  (void)can::enable_rx_timestamps(sock.fd(), error);
  (void)can::enable_rx_drop_count(sock.fd(), error);  // where unsupported, drops show as partial cycles only
  sock_ = std::move(sock);
  const std::int64_t now = mono_now_ns();
  service_network(now);  // the nodes' checks begin (SDO), or they are started
  last_rx_ns_ = now;
  read_at_ns_ = now;
  next_sync_ns_ = now;
  // Short SYNC periods: wake once per cycle, at the SYNC, and read the previous cycle's PDOs then
  // (the sample is published up to one period later, <= 500 us). Longer periods also wake for the
  // PDOs, so a sample never waits a long period. A wake-up costs far more than the system calls.
  // With events 0 the bus still reports hang-up and errors, so a lost connection wakes us.
  const std::int64_t period_ns =
      settings_.produce_sync ? static_cast<std::int64_t>(std::llround(1e9 / settings_.sync_rate_hz)) : 0;
  const bool one_wake_per_cycle = settings_.produce_sync && period_ns <= max_batched_sync_period_ns;
  io_->watch(sock_.fd(), one_wake_per_cycle || batched() ? 0u : std::uint32_t{EPOLLIN},
             [this](std::uint32_t events) { on_ready(events); });
  step();
}

void DbbDriver::end_connection(const std::string& why) {
  io_->unwatch(sock_.fd());
  sock_.reset();
  DbbCycle rest;
  if (decoder_->flush(rest)) publish_cycle(rest);  // nothing received is lost
  decoder_->resync();
  set_state_directly(drivers::DeviceState::lost, why);
  reconnect_at_ns_ = mono_now_ns() + backoff_.take_ns();
  io_->arm(timer_, reconnect_at_ns_);
}

void DbbDriver::on_timer() {
  if (!sock_.valid()) {
    if (mono_now_ns() >= reconnect_at_ns_) {
      connect();
    } else {
      io_->arm(timer_, reconnect_at_ns_);
    }
    return;
  }
  step();
}

void DbbDriver::on_ready(std::uint32_t events) {
  if (!sock_.valid()) return;
  std::string ended;
  if ((events & (EPOLLHUP | EPOLLERR)) != 0) {
    // The connection ends: every frame still queued first (EOF or the error comes after them).
    bool more = true;
    while (more && ended.empty()) {
      if (drain(ended, more) > 0) last_rx_ns_ = mono_now_ns();
    }
    if (ended.empty()) {
      int err = 0;
      socklen_t len = sizeof err;
      (void)::getsockopt(sock_.fd(), SOL_SOCKET, SO_ERROR, &err, &len);
      ended = err != 0 ? std::string("socket error: ") + std::strerror(err) : "connection hung up";
    }
    end_connection(ended);
    return;
  }
  if (batched()) {
    read_at_ns_ = mono_now_ns();  // a frame after a read that found none: read now
    step_batched();
    return;
  }
  // Every frame queued (a whole cycle's PDOs usually arrive together): one recvmmsg, one wake-up.
  if (drain(ended, drain_pending_) > 0) last_rx_ns_ = mono_now_ns();
  if (!ended.empty()) {  // EOF comes after every queued frame was read
    end_connection(ended);
    return;
  }
  step();
}

void DbbDriver::on_settle() {
  if (!idle_check_ || !sock_.valid()) return;
  idle_check_ = false;
  if (io_->data_found_this_pass()) return;  // others stream: read again at their next pass
  // Nothing anywhere: a silent bus costs no periodic wake-ups; the next frame wakes us.
  read_at_ns_ = mono_now_ns();
  resting_ = false;
  io_->modify(sock_.fd(), EPOLLIN);
  io_->arm(timer_, std::min(last_rx_ns_ + settings_.timeout_ms * 1'000'000, network_.next_deadline()));
}

void DbbDriver::on_wake() {
  // Only a batched reader that rests, and only when this pass has not served it already.
  if (!sock_.valid() || served_pass_ == io_->passes() || io_->now() >= read_at_ns_) return;
  step_batched(true);
}

void DbbDriver::step() {
  if (batched()) {
    step_batched();
    return;
  }
  const std::int64_t period_ns =
      settings_.produce_sync ? static_cast<std::int64_t>(std::llround(1e9 / settings_.sync_rate_hz)) : 0;
  const std::int64_t timeout_ns = settings_.timeout_ms * 1'000'000;
  std::string error;
  std::string ended;
  if (drain_pending_) {  // frames left by a flood: read on before anything else
    if (drain(ended, drain_pending_) > 0) last_rx_ns_ = mono_now_ns();
    if (!ended.empty()) {
      end_connection(ended);
      return;
    }
  }
  std::int64_t now = mono_now_ns();
  // Before the network's timers: a silent bus is shown as such first, then what the nodes say.
  if (now - last_rx_ns_ >= timeout_ns) note_silence(now);
  if (settings_.produce_sync && now >= next_sync_ns_) {
    // Frames already queued were on the bus before this SYNC: consume them first, so a cycle's
    // last PDO waiting in the socket is not cut off by our own next SYNC.
    if (drain(ended, drain_pending_) > 0) last_rx_ns_ = mono_now_ns();
    if (!ended.empty()) {  // EOF comes after every queued frame was read
      end_connection(ended);
      return;
    }
    const can_frame sync = make_sync_frame();
    // Never wait for the bus: a full transmit queue (nobody acknowledges, or the gateway's peer does
    // not read) costs this SYNC, counted; the silence that follows is a timeout as usual.
    // The SYNC's time is taken just before it is written: a PDO stamped before then answers an earlier
    // SYNC. Taken after the write, a thread preempted between the write and the clock read would give
    // the nodes' answers to this SYNC to the cycle before (which they complete, leaving this one
    // partial); a late answer stamped during the write itself is still recognised (late_pdos).
    const std::int64_t sync_ns = mono_now_ns();
    const auto wrote = can::try_write_can_frame(sock_.fd(), sync, error);
    now = mono_now_ns();
    if (wrote == can::WriteResult::failed) {
      bool more = false;
      drain(ended, more);
      end_connection("SYNC write failed: " + error);
      return;
    }
    DbbCycle cycle;
    if (wrote == can::WriteResult::queue_full) {
      syncs_not_sent_.fetch_add(1, std::memory_order_relaxed);
    } else if (decoder_->sync_sent(sync_ns, cycle)) {
      publish_cycle(cycle);
    }
    // The phase is kept, but a late SYNC never brings the next one closer than half a period: the
    // nodes need that time to answer, and a PDO that comes after our next SYNC is a late one.
    next_sync_ns_ += period_ns;
    if (next_sync_ns_ < now + period_ns / 2) next_sync_ns_ = now + period_ns;
  }
  now = mono_now_ns();
  service_network(now);
  std::int64_t deadline = std::min(last_rx_ns_ + timeout_ns, network_.next_deadline());
  if (settings_.produce_sync) deadline = std::min(deadline, next_sync_ns_);
  if (drain_pending_) {
    deadline = now;
    io_->again();
  }
  io_->arm(timer_, deadline);
}

void DbbDriver::step_batched(bool opportunistic) {
  // Read, then rest for read_period_us while frames queue up in the socket (each keeps its kernel
  // receive time, so the SYNC's time is exact however late it is read), then read again. A read that
  // finds nothing waits for the next frame instead, so a silent bus costs no periodic wake-ups. When
  // SYNCs come further apart than the period and the read completed its cycle, there is nothing to
  // batch: wait for the next SYNC at once. So at high SYNC rates one wake-up per period; at low rates
  // one per cycle when a cycle's frames arrive together (the emulator), two on a real bus (the SYNC
  // precedes the PDOs by at least a frame time: it wakes us, we rest, then read the PDOs). A frame
  // waits at most read_period_us in the socket. While it rests, any other pass of the loop (another
  // device, a timer) reads it too, and its rest starts again from there: devices served by one loop
  // thus fall into step and share one wake-up per period. A rest that ends with an empty read waits
  // for the next frame only when no other device found data in that pass (on_settle): while others
  // stream it is read at their passes, and waking on its own next frame would be one more wake-up.
  const std::int64_t period_ns = settings_.read_period_us * 1000;
  const std::int64_t timeout_ns = settings_.timeout_ms * 1'000'000;
  std::int64_t now = mono_now_ns();
  if (opportunistic || now >= read_at_ns_) {
    std::string ended;
    bool more = false;
    const std::size_t got = drain(ended, more);
    if (!ended.empty()) {  // EOF comes after every queued frame was read
      end_connection(ended);
      return;
    }
    now = mono_now_ns();
    if (got > 0) {
      io_->data_found();
      last_rx_ns_ = now;
      const bool slow_bus = sync_period_ns_ > period_ns && !decoder_->cycle_pending();
      read_at_ns_ = slow_bus || more ? now : now + period_ns;
    } else {
      // Read just now, at another device's pass or at the end of a rest: rest on (the end of a rest
      // is settled once the pass has read every device). A read on readiness that found nothing
      // (the first one, a spurious wake-up) waits for the next frame.
      if (opportunistic || resting_) read_at_ns_ = now + period_ns;
      idle_check_ = !opportunistic && resting_;
      if (now - last_rx_ns_ >= timeout_ns) note_silence(now);
    }
  }
  served_pass_ = io_->passes();
  service_network(now);
  const bool resting = now < read_at_ns_;
  resting_ = resting;
  // Resting: events 0, so only hang-up and errors end the rest early (and are read at once). Else the
  // next frame wakes us (a flood's frames left behind: at once, after the other devices).
  io_->modify(sock_.fd(), resting ? 0u : std::uint32_t{EPOLLIN});
  io_->arm(timer_, std::min(resting ? read_at_ns_ : last_rx_ns_ + timeout_ns, network_.next_deadline()));
}

void register_dbb_driver(drivers::DriverRegistry& registry) {
  registry.add("dbb-can",
               "double ball bar + axis encoders on CAN (CANopen CiA 301/406 nodes: NMT, SDO checks, TPDOs on SYNC; "
               "SocketCAN or unix: gateway)",
               [](const drivers::DeviceConfig& c) {
                 return std::make_unique<DbbDriver>(c.name, c.ring_capacity, parse_dbb_settings(c.table));
               });
}

}  // namespace guideway::drivers::dbb
