// "dbb-can" (dbb_driver.hpp): the ballbar's and the axes' CANopen encoders on one CAN bus, read on an I/O loop, one
// sample per SYNC.
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
  // controller_period: a virtual machine's servo period number (docs/linuxcnc.md), not a length.
  for (const auto& e : s.encoders) out.push_back({e.channel, e.channel == "controller_period" ? "" : "m"});
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
  s.reconnect = drivers::read_reconnect(t, std::chrono::milliseconds(50), std::chrono::milliseconds(5000));
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

namespace {

std::int64_t sync_period_ns(const DbbSettings& s) {
  return static_cast<std::int64_t>(std::llround(1e9 / s.sync_rate_hz));
}

drivers::LoopPolicy policy_of(const DbbSettings& s) {
  drivers::LoopPolicy p;
  p.reconnect = s.reconnect;
  p.unreached_is_error = true;  // a bus that was never there is a wrong interface or path
  const std::int64_t period_ns = s.produce_sync ? sync_period_ns(s) : 0;
  // Short SYNC periods: wake once per cycle, at the SYNC, and read the previous cycle's PDOs then
  // (the sample is published up to one period later, <= 500 us). Longer periods also wake for the
  // PDOs, so a sample never waits a long period. A wake-up costs far more than the system calls.
  // Listening, the bus is read in batches at most once per read_period_us (frames keep their kernel
  // receive times): at high SYNC rates one wake-up per period; at low rates one per cycle when a
  // cycle's frames arrive together, two on a real bus (the SYNC precedes the PDOs by a frame time).
  if (s.produce_sync) {
    p.schedule = period_ns <= DbbDriver::max_batched_sync_period_ns ? drivers::ReadSchedule::paced
                                                                     : drivers::ReadSchedule::per_arrival;
  } else {
    p.schedule = s.read_period_us > 0 ? drivers::ReadSchedule::rest : drivers::ReadSchedule::per_arrival;
  }
  p.read_period_ns = s.read_period_us * 1000;
  p.alone_reads_per_arrival = false;  // the slow-bus rule decides (rest_after)
  p.silence_ns = s.timeout_ms * 1'000'000;
  // Twice the silence: the bus's own story (no frames, a node's silence or reboot) is told first.
  p.sample_bound_ns = 2 * p.silence_ns;
  return p;
}

}  // namespace

DbbDriver::DbbDriver(std::string name, std::size_t ring_capacity, DbbSettings settings, CanConnector connector)
    : LoopDriver(std::move(name), "dbb-can", channels_of(settings), ring_capacity, policy_of(settings)),
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

void DbbDriver::forget_shown_state() {
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
  // The note tells how the last trouble ended: it goes when streaming that showed it ends, not in a
  // quiet spell between a recovery and the first cycles (nobody saw the recovery yet).
  if (state != drivers::DeviceState::streaming && shown_state_ == drivers::DeviceState::streaming) note_.clear();
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

drivers::ReadOutcome DbbDriver::read_some(bool) {
  std::array<can_frame, 32> frames{};
  std::array<std::int64_t, 32> rx_realtime_ns{};
  std::string error;
  drivers::ReadOutcome out;
  std::size_t& records = out.taken;
  bus_reads_.fetch_add(1, std::memory_order_relaxed);
  for (;;) {
    if (records >= max_drain_frames) {  // a flooding bus: the other devices first, then on
      out.more = true;
      return out;
    }
    const std::int64_t read_start = mono_now_ns();
    can::FrameBatch batch;
    const can::ReadResult r = can::read_can_frames(sock_.fd(), frames, rx_realtime_ns, batch, error);
    if (r == can::ReadResult::closed) out.ended = "connection closed by the bus";
    if (r == can::ReadResult::error) out.ended = error;
    if (r != can::ReadResult::frame) {
      prev_read_ns_ = read_start;
      if (records == 0) empty_reads_.fetch_add(1, std::memory_order_relaxed);
      return out;
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
      return out;
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
  if (res.info.kind == FrameInfo::Kind::sync && !settings_.produce_sync) {  // a producer's echo: its own period
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

void DbbDriver::on_silence(std::int64_t) {
  timeouts_.fetch_add(1, std::memory_order_relaxed);
  // A bus that is off is silent: its state stays the error that says why (refresh_state).
  silent_ = true;
  state_dirty_ = true;
  decoder_->mark_gap();  // what comes next follows a gap
}

bool DbbDriver::rest_after(const drivers::ReadOutcome&) const {
  return !(sync_period_ns_ > settings_.read_period_us * 1000 && !decoder_->cycle_pending());
}

void DbbDriver::open() {
  std::string error;
  prev_read_ns_ = mono_now_ns();  // no frame on this connection was received before it was opened
  kernel_drops_ = 0;
  can::CanSocket sock = connector_(error);
  if (!sock.valid()) {
    forget_shown_state();
    link_failed(to_string(settings_.endpoint) + ": " + error);
    return;
  }
  // Kernel receive times for every frame (SocketCAN and AF_UNIX sockets support them). The standard
  // endpoints enable them before bind/connect (else frames queued meanwhile would be stamped at the
  // read); this covers other connectors. Should a socket refuse, frames get the time they are read,
  // counted in untimed_frames.
  (void)can::enable_rx_timestamps(sock.fd(), error);
  (void)can::enable_rx_drop_count(sock.fd(), error);  // where unsupported, drops show as partial cycles only
  // Our SYNC back among the PDOs says which cycle each answers (DbbDecoder); the gateway echoes it unasked,
  // and without an echo the decoder assigns by the frames' times.
  if (settings_.produce_sync) (void)can::enable_own_frames(sock.fd(), error);
  sock_ = std::move(sock);
  link_up(sock_.fd());
}

void DbbDriver::on_link_up(std::int64_t now_ns) {
  if (!relinked()) {
    decoder_.emplace(settings_.encoders, settings_.produce_sync, sync_period_ns(settings_));
  }
  // Nothing is known of the nodes on a new connection: checked and started again, streaming again
  // from the first complete cycle.
  network_.connected(now_ns);
  complete_cycle_seen_ = false;
  note_.clear();
  bus_off_since_ns_ = 0;
  forget_shown_state();
  silent_ = false;
  last_sync_ns_ = 0;
  sync_period_ns_ = 0;
  drain_pending_ = false;
  next_sync_ns_ = now_ns;
  last_sync_sent_ns_ = 0;
}

void DbbDriver::on_link_down() {
  sock_.reset();
  DbbCycle rest;
  if (decoder_->flush(rest)) publish_cycle(rest);  // nothing received is lost
  decoder_->resync();
  forget_shown_state();
}

std::int64_t DbbDriver::service(std::int64_t now) {
  if (settings_.produce_sync) {
    if (drain_pending_ && !read_queued(drain_pending_)) return drivers::IoLoop::never;  // a flood's frames first
    if (mono_now_ns() >= next_sync_ns_ && !send_sync()) return drivers::IoLoop::never;
    now = mono_now_ns();
  }
  service_network(now);
  std::int64_t deadline = network_.next_deadline();
  if (settings_.produce_sync) deadline = std::min(deadline, next_sync_ns_);
  if (drain_pending_) deadline = now;
  return deadline;
}

bool DbbDriver::send_sync() {
  // Frames already queued were on the bus before this SYNC: consume them first, so a cycle's last PDO
  // waiting in the socket is not cut off by our own next SYNC.
  if (!read_queued(drain_pending_)) return false;
  const std::int64_t period_ns = sync_period_ns(settings_);
  const can_frame sync = make_sync_frame();
  std::string error;
  // Never wait for the bus: a full transmit queue (nobody acknowledges, or the gateway's peer does
  // not read) costs this SYNC, counted; the silence that follows is a timeout as usual.
  // The SYNC's time is taken just before it is written, and again when the write returned: the SYNC
  // reached the bus in between, so an answer stamped before the second may still be the cycle
  // before's (the decoder gives it there when nothing of that cycle had come: nodes answering the
  // earlier SYNC while this thread was held up between the clock read and the write); one stamped
  // after it is this SYNC's, or a late answer to the one before that the next answer replaces (late_pdos).
  const std::int64_t sync_ns = mono_now_ns();
  const auto wrote = can::try_write_can_frame(sock_.fd(), sync, error);
  const std::int64_t now = mono_now_ns();
  if (wrote == can::WriteResult::failed) {
    bool more = false;
    if (read_queued(more)) end_link("SYNC write failed: " + error);
    return false;
  }
  DbbCycle cycle;
  // A hole in the samples is flagged on the sample after it (sample_after_gap): SYNCs two periods or
  // more apart (the loop was held up), a SYNC the bus did not take, a SYNC no node answered (the decoder).
  if (wrote == can::WriteResult::queue_full) {
    syncs_not_sent_.fetch_add(1, std::memory_order_relaxed);
    decoder_->mark_gap();
  } else {
    if (last_sync_sent_ns_ != 0 && sync_ns - last_sync_sent_ns_ >= 2 * period_ns) decoder_->mark_gap();
    last_sync_sent_ns_ = sync_ns;
    if (decoder_->sync_sent(sync_ns, now, cycle)) publish_cycle(cycle);
  }
  // The phase is kept, but a late SYNC never brings the next one closer than half a period: the
  // nodes need that time to answer, and a PDO that comes after our next SYNC is a late one.
  next_sync_ns_ += period_ns;
  if (next_sync_ns_ < now + period_ns / 2) next_sync_ns_ = now + period_ns;
  return true;
}

void register_dbb_driver(drivers::DriverRegistry& registry) {
  registry.add("dbb-can",
               "double ball bar + axis encoders on CAN (CANopen CiA 301/406 nodes: NMT, SDO checks, TPDOs on SYNC; "
               "SocketCAN or unix: gateway)",
               [](const drivers::DeviceConfig& c) {
                 DbbSettings s = parse_dbb_settings(c.table);
                 // One sample per SYNC: the producer's rate, or the controller's as configured (listen).
                 const std::size_t ring = c.ring_for(s.sync_rate_hz);
                 return std::make_unique<DbbDriver>(c.name, ring, std::move(s));
               });
}

}  // namespace guideway::drivers::dbb
