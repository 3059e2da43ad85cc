#pragma once
// "dbb-can": the double ball bar's length encoder plus two axis encoders on one CAN bus, CANopen
// CiA 406 encoders (PDOs: dbb_protocol.hpp; checking and starting the nodes: dbb_network.hpp). One
// Sample per SYNC: values in the order of the configured encoders, in metres, timestamped at the SYNC.
// The state is `streaming` only while every node delivers. On the driver skeleton
// (drivers/loop_driver.hpp): the socket's readiness and timers (SYNC, read period, silence, the
// network's SDO, heartbeat and retry timers, the reconnect back-off) drive it. Thread safety: as
// drivers::Driver.

#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "drivers/can/can_io.hpp"
#include "drivers/dbb/dbb_network.hpp"
#include "drivers/dbb/dbb_protocol.hpp"
#include "drivers/loop_driver.hpp"

namespace guideway::drivers::dbb {

// Listen mode's read period (drivers::default_read_period_us).
inline constexpr std::int64_t default_read_period_us = drivers::default_read_period_us;

struct DbbSettings {
  can::CanEndpoint endpoint;    // can:IFNAME or unix:PATH
  bool produce_sync = true;     // true: we are the SYNC producer; false: listen only
  double sync_rate_hz = 100.0;  // when producing SYNC
  // sync = "listen": read the bus at most once per read_period_us (frames keep their kernel receive
  // times); 0: wake for every frame arrival. See docs/protocols.md for the default.
  std::int64_t read_period_us = default_read_period_us;
  std::int64_t timeout_ms = 500;       // silence after which the device is "lost" (one timeout counted per period)
  // The back-off between failed connects (reconnect_min_ms 50, reconnect_max_ms 5000).
  drivers::Reconnect reconnect{Backoff{0.05, 5.0}, {}};
  std::vector<EncoderScale> encoders;
  // CANopen network management (dbb_network.hpp): NMT, SDO checks, heartbeat consumer. Its
  // pdo_timeout_ms is always timeout_ms (the driver sets it).
  NetworkSettings network;
  std::vector<NodeExpectation> nodes;  // one per encoder
};

// Reads the settings from a [[device]] table (every accepted key; errors carry file:line:key).
DbbSettings parse_dbb_settings(const TableReader& table);

// When a frame was received, on the monotonic clock: its kernel receive time `rx_realtime_ns`
// (CLOCK_REALTIME, can::no_rx_timestamp if none) minus `realtime_offset_ns` (realtime_minus_mono_ns()
// sampled at the read). A frame read at `read_ns` was queued after `earliest_ns` (the previous read
// found the socket empty); a stamp outside [earliest_ns, read_ns] by more than 1 ms is not this
// frame's time on our clock (the real-time clock was stepped between stamp and read), and a frame
// without one gets `read_ns` too, with from_kernel false.
struct FrameTime {
  std::int64_t t_ns = 0;
  bool from_kernel = false;
};
FrameTime frame_time(std::int64_t rx_realtime_ns, std::int64_t realtime_offset_ns, std::int64_t earliest_ns,
                     std::int64_t read_ns) noexcept;
// Makes the times of one read's frames (in arrival order) never go backwards, on this connection too:
// a frame without a kernel time (none, or a clock step put it outside the window) gets the next
// kernel time of the batch instead of the read time where there is one (it was received before that
// frame), and every time is raised to at least `last_ns`, the last time emitted, which it updates.
// A step that happens between two reads is caught only if it is larger than the window plus the 1 ms
// slack: a smaller one shifts that read's frames by the size of the step, undetected. The window is
// normally one read period, but after the bus was silent up to timeout_ms (at most 1 s).
void order_frame_times(std::span<FrameTime> times, std::int64_t& last_ns) noexcept;

// The CAN_RAW_FILTER set a dbb-can SocketCAN socket gets: the SYNC (0x080) and, of each configured
// node, its TPDO1 (0x180 + node), EMCY (0x080 + node), SDO responses (0x580 + node) and boot-up and
// heartbeat (0x700 + node); standard data frames only; error frames come through CAN_RAW_ERR_FILTER.
std::vector<can_filter> dbb_can_filters(const DbbSettings& settings);

// Opens the bus; tests substitute one that hands out socketpair ends.
using CanConnector = std::function<can::CanSocket(std::string& error)>;

class DbbDriver : public drivers::LoopDriver {
 public:
  // SYNC periods up to this (sync_rate_hz >= 2000) are served with one wake-up per cycle: the PDOs
  // are read just before the next SYNC instead of as they arrive.
  static constexpr std::int64_t max_batched_sync_period_ns = 500'000;
  DbbDriver(std::string name, std::size_t ring_capacity, DbbSettings settings, CanConnector connector = {});
  ~DbbDriver() override;

  [[nodiscard]] std::uint64_t error_frames() const noexcept { return error_frames_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t partial_cycles() const noexcept {
    return partial_cycles_.load(std::memory_order_relaxed);
  }
  // Frames whose kernel receive timestamp was missing or implausible (a clock step): they got the
  // time they were read instead.
  [[nodiscard]] std::uint64_t untimed_frames() const noexcept {
    return untimed_frames_.load(std::memory_order_relaxed);
  }
  // Frames the kernel dropped because the socket's receive queue was full (SO_RXQ_OVFL; SocketCAN
  // reports them, a Unix gateway never drops): also counted in bad_frames, so STATUS shows the loss.
  [[nodiscard]] std::uint64_t dropped_frames() const noexcept {
    return dropped_frames_.load(std::memory_order_relaxed);
  }
  // Reads of the bus (each takes every queued frame): in listen mode with read_period_us > 0 about
  // one per wake-up.
  [[nodiscard]] std::uint64_t bus_reads() const noexcept { return bus_reads_.load(std::memory_order_relaxed); }
  // Reads that found the socket empty (a rest that ended with nothing queued, a spurious wake-up).
  [[nodiscard]] std::uint64_t empty_reads() const noexcept { return empty_reads_.load(std::memory_order_relaxed); }
  [[nodiscard]] const DbbSettings& settings() const noexcept { return settings_; }
  // error_frames, partial_cycles, untimed_frames, dropped_frames. Not bus_reads/empty_reads: they
  // count the reader's wake-ups (a CPU cost), not what happened to the data.
  [[nodiscard]] std::vector<drivers::NamedCounter> driver_counters() const override;
 protected:
  // Opens the bus, or (refused) says why: the skeleton tries again after the back-off.
  void open() override;
  void on_link_up(std::int64_t now_ns) override;
  // Consumes the frames already queued, without waiting, each at its kernel receive time. At most
  // max_drain_frames at once (`more`: a flooding bus, read on at the next pass).
  drivers::ReadOutcome read_some(bool at_others_pass) override;
  // SYNC production (reading the cycle before each SYNC), the network's timers, the state.
  std::int64_t service(std::int64_t now_ns) override;
  // No frame for timeout_ms: one timeout, state lost, the next cycle flagged after a gap (the bus stays open).
  void on_silence(std::int64_t now_ns) override;
  // The slow-bus rule: SYNCs further apart than the read period and the cycle complete: nothing to
  // batch, the next SYNC is read when it comes.
  [[nodiscard]] bool rest_after(const drivers::ReadOutcome& read) const override;
  // Publishes what the decoder holds.
  void on_link_down() override;

 private:
  void publish_cycle(const DbbCycle& cycle);
  // Runs the network's timers, sends its frames, posts its events and sets the device state.
  void service_network(std::int64_t now);
  // The device state from bus-off, silence, the nodes and the cycles; set_state only when it changed.
  void refresh_state();
  // The state was set outside refresh_state (the link): refresh_state's memory of what it set is void.
  void forget_shown_state();
  // produce mode: the queued cycle, then this SYNC; false when the link ended.
  bool send_sync();
  void handle_frame(const can_frame& frame, std::int64_t t_ns);
  static constexpr std::size_t max_drain_frames = 1024;

  DbbSettings settings_;
  CanConnector connector_;
  // The loop thread's:
  std::optional<DbbDecoder> decoder_;
  can::CanSocket sock_;
  std::int64_t next_sync_ns_ = 0;      // produce: the next SYNC
  std::int64_t last_sync_sent_ns_ = 0;  // produce: the last SYNC the bus took (0: none on this link)
  bool drain_pending_ = false;         // paced: frames were left in the socket (more than max_drain_frames)
  bool silent_ = false;                // lost/bus-off until the next sample
  std::int64_t bus_off_since_ns_ = 0;  // bus off since then, until it recovers (0 = not)
  std::int64_t prev_read_ns_ = 0;      // when a read last found the socket empty
  std::uint32_t kernel_drops_ = 0;     // the socket's total drops reported so far
  std::int64_t last_frame_ns_ = 0;     // the time given to the last frame received (never decreases)
  std::atomic<std::uint64_t> error_frames_{0};
  std::atomic<std::uint64_t> bus_offs_{0};
  std::atomic<std::uint64_t> late_pdos_{0};       // the decoder's, for status()
  std::atomic<std::uint64_t> syncs_not_sent_{0};  // produce mode: SYNCs the full transmit queue refused
  std::atomic<std::uint64_t> partial_cycles_{0};
  std::atomic<std::uint64_t> untimed_frames_{0};
  std::atomic<std::uint64_t> dropped_frames_{0};
  std::atomic<std::uint64_t> frames_not_sent_{0};  // NMT/SDO frames the full transmit queue refused
  std::atomic<std::uint64_t> boot_ups_{0};         // network counters, copied for status()
  std::atomic<std::uint64_t> heartbeat_timeouts_{0};
  std::atomic<std::uint64_t> emcys_{0};
  std::atomic<std::uint64_t> sdo_aborts_{0};
  std::atomic<std::uint64_t> sdo_timeouts_{0};
  std::atomic<std::uint64_t> nmt_starts_{0};
  std::atomic<std::uint64_t> bus_reads_{0};
  std::atomic<std::uint64_t> empty_reads_{0};
  EncoderNetwork network_;                   // loop thread
  bool complete_cycle_seen_ = false;         // loop thread: since the connection
  std::string note_;                         // loop thread: the reason shown with `streaming` (a recovery)
  bool state_dirty_ = true;                  // loop thread: refresh_state has something to look at
  std::uint64_t state_network_version_ = 0;  // loop thread: network_.health_version() refresh_state saw
  drivers::DeviceState shown_state_ = drivers::DeviceState::stopped;  // loop thread: what refresh_state set
  std::string shown_reason_;
  std::int64_t last_sync_ns_ = 0;    // loop thread: receive time of the newest SYNC (0: none yet)
  std::int64_t sync_period_ns_ = 0;  // loop thread: between the last two SYNCs received
};

void register_dbb_driver(drivers::DriverRegistry& registry);

}  // namespace guideway::drivers::dbb
