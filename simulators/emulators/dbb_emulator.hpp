#pragma once
// An emulated DBB bus: the bar's length encoder and two axis encoders answering SYNC with TPDO1
// position values (or producing SYNC themselves, like a CNC controller would), over any fd carrying
// can_frame records: a socketpair end handed in by a test, a Unix SEQPACKET gateway socket, or a
// SocketCAN interface. Values come from a DbbSource (the virtual machine tool). Faults are injected
// from any thread; everything the emulator sent is logged so tests can compare the driver's samples.
// Thread safe: start/stop from one thread; inject_*, attach, log() from any thread.

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "drivers/can/can_io.hpp"
#include "drivers/dbb/dbb_protocol.hpp"
#include "simulators/emulators/canopen_node.hpp"

namespace guideway::simulators::emulators {

// What the encoders see at time t_s (seconds since the emulator started): one position in metres per
// configured encoder, in encoder order.
using DbbSource = std::function<void(double t_s, std::span<double> positions_m)>;

struct DbbEmulatorSettings {
  std::vector<drivers::dbb::EncoderScale> encoders;
  bool produce_sync = false;  // false: answer the driver's SYNC; true: we send SYNC at sync_rate_hz
  double sync_rate_hz = 100.0;
  // The nodes are CANopen nodes (canopen_node.hpp): powered on when the emulator starts, pre-operational
  // until an NMT start (unless they start themselves), answering SDO.
  std::uint16_t heartbeat_ms = 0;               // 0x1017 at power-on (0: no heartbeats)
  std::uint8_t transmission_type = 1;           // 0x1800:2 at power-on
  bool nodes_start_operational = false;         // the nodes start themselves (auto-start), no NMT master needed
  std::vector<EncoderNodeIdentity> identities;  // per encoder; missing: EncoderNodeIdentity{} (serial 1000 + node)
};

// One cycle the emulator put on the bus.
struct DbbSentCycle {
  double t_s = 0;
  std::int64_t t_mono_ns = 0;         // CLOCK_MONOTONIC just before the cycle was written
  std::uint32_t sent_mask = 0;        // bit i: encoder i's PDO was sent
  std::vector<double> truth_m;        // the source's positions
  std::vector<std::uint32_t> counts;  // the counts sent
  // Answering a SYNC (listen mode): the next SYNC was already there when the PDOs had been written, so on
  // the bus some of them may follow it (a late answer; a loaded machine delays this thread).
  bool late = false;
};

class DbbEmulator {
 public:
  DbbEmulator(DbbEmulatorSettings settings, DbbSource source);
  ~DbbEmulator();
  DbbEmulator(const DbbEmulator&) = delete;
  DbbEmulator& operator=(const DbbEmulator&) = delete;

  // Serve connections accepted on `listener` (a listening Unix SEQPACKET socket), one at a time,
  // and/or fds handed in with attach(). Starts the emulator thread.
  void start(drivers::can::CanSocket listener = {});
  void stop();
  // Serves `fd` from now on (the previous connection is closed). Takes ownership.
  void attach(drivers::can::CanSocket fd);

  // Fault injection: applied at the next cycle (before its PDOs) unless said otherwise.
  void inject_disconnect();                                    // close the connection now
  void inject_garbage(int frames);                             // frames with foreign COB-IDs and random payloads
  void inject_truncated(int frames);                           // records shorter than a can_frame
  void inject_bad_frames(int frames);                          // TPDO1s with a wrong length, SYNC with a payload
  void inject_error_frames(int frames);  // CAN_ERR_FLAG frames (protocol or controller errors)
  // The controller goes bus-off: a CAN_ERR_BUSOFF error frame, nothing on the bus for restart_ms (the
  // controller's restart-ms), then a CAN_ERR_RESTARTED error frame and the cycles again.
  void inject_bus_off(int restart_ms = 200);
  void inject_drop_pdo(std::size_t encoder, int cycles);  // that encoder skips its PDO in the next cycles
  void inject_stall(double seconds);                      // answer/produce nothing for a while
  void inject_burst(int cycles);                          // that many extra SYNC+PDO cycles, back to back
  // CANopen node faults (applied at once; `encoder` is the index in the encoder list):
  void inject_reboot(std::size_t encoder, double down_s);                // power off, then boot-up (pre-operational)
  void inject_mute(std::size_t encoder, double seconds);                 // no heartbeat, PDO or SDO answer for a while
  void inject_sdo_abort(std::size_t encoder, std::uint32_t abort_code);  // abort every SDO request (0: off)
  void inject_identity(std::size_t encoder, EncoderNodeIdentity identity);  // another device under that node-ID
  void inject_emcy(std::size_t encoder, std::uint16_t error_code, std::uint8_t error_register);
  // The nodes' NMT states (boot_up while powered off), in encoder order, as of the emulator's last loop.
  [[nodiscard]] std::vector<drivers::can::NmtState> node_states() const;

  // The cycles in which at least one node sent its PDO (a SYNC no node answered is no cycle).
  [[nodiscard]] std::vector<DbbSentCycle> log() const;
  [[nodiscard]] std::uint64_t cycles_sent() const noexcept { return cycles_.load(); }
  [[nodiscard]] std::uint64_t connections() const noexcept { return connections_.load(); }
  [[nodiscard]] bool connected() const noexcept { return connected_.load(); }

 private:
  void loop();
  void wake();
  void send_cycle(int fd, int syncs);  // syncs: SYNC frames ahead of the answers (ours, or echoes)
  bool send_faults(int fd, std::vector<can_frame>& batch);
  void close_conn();
  // Node faults queued by inject_*, the nodes' own frames (heartbeats, SDO answers): on the loop's thread.
  void run_node_commands(std::int64_t now, std::vector<can_frame>& out);
  void node_command(std::size_t encoder, std::function<void(EncoderNode&, std::int64_t, std::vector<can_frame>&)> f);
  void send_node_frames(std::vector<can_frame>& out);

  DbbEmulatorSettings settings_;
  DbbSource source_;
  std::int64_t t0_ns_ = 0;
  drivers::can::CanSocket listener_;
  drivers::can::CanSocket conn_;
  int wake_fd_ = -1;
  std::jthread thread_;
  std::atomic<bool> running_{false};
  std::atomic<bool> stopped_{false};  // stop() was called: attach() hangs up

  std::mutex pending_mutex_;
  drivers::can::CanSocket pending_;
  bool has_pending_ = false;

  std::atomic<bool> disconnect_{false};
  std::atomic<int> garbage_{0}, truncated_{0}, bad_{0}, error_frames_{0}, burst_{0};
  std::atomic<bool> bus_off_{false};              // a BUSOFF frame to send
  std::atomic<std::int64_t> bus_off_until_ns_{0};  // silent until then, then RESTARTED
  std::atomic<bool> restarted_{false};             // a RESTARTED frame to send
  std::atomic<std::int64_t> stall_until_ns_{0};
  std::mutex drop_mutex_;
  std::vector<int> drop_cycles_;    // per encoder
  std::vector<EncoderNode> nodes_;  // emulator thread
  mutable std::mutex node_mutex_;
  std::vector<std::function<void(std::int64_t, std::vector<can_frame>&)>> node_commands_;  // under node_mutex_
  std::vector<drivers::can::NmtState> node_states_;                                        // under node_mutex_
  std::uint32_t rng_ = 12345;

  mutable std::mutex log_mutex_;
  std::vector<DbbSentCycle> log_;
  std::atomic<std::uint64_t> cycles_{0};
  std::atomic<std::uint64_t> connections_{0};
  std::atomic<bool> connected_{false};
};

// A DBB circle without a machine model: the tool runs a circle of `radius_m` around the centre pivot
// at `feed_m_s` (ccw when direction > 0); the bar reads the exact pivot distance plus `bar_error_m`.
// Encoder order: bar_length, first axis, second axis.
DbbSource ideal_circle_source(double radius_m, double feed_m_s, int direction, double bar_error_m = 0.0);

}  // namespace guideway::simulators::emulators
