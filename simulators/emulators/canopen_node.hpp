#pragma once
// One emulated CANopen encoder node (CiA 301 communication, CiA 406 linear encoder objects), as a
// real one behaves: after power-on it sends its boot-up message and is pre-operational (no PDOs);
// NMT commands move it between pre-operational, operational and stopped, or reset it (boot-up again,
// power-on values restored: what an SDO wrote without "store parameters" is gone); it produces its
// heartbeat every 0x1017 ms; its SDO server answers expedited uploads and downloads of its object
// dictionary (or aborts with the standard's codes); on SYNC it transmits TPDO1 only when
// operational, with a synchronous transmission type, every n-th SYNC for type n.
// Frames in, frames out (appended to `out`), time passed in: no I/O. Not thread safe.

#include <linux/can.h>

#include <cstdint>
#include <vector>

#include "drivers/can/canopen.hpp"
#include "drivers/dbb/dbb_protocol.hpp"

namespace guideway::simulators::emulators {

struct EncoderNodeIdentity {
  std::uint32_t vendor_id = 0x47570000;  // made up for the emulator ("GW"); real ones are assigned by CiA
  std::uint32_t product_code = 406;
  std::uint32_t revision_number = 0x00010000;
  std::uint32_t serial_number = 0;  // 0: 1000 + node-ID
};

struct EncoderNodeSettings {
  drivers::dbb::EncoderScale scale;  // node-ID and resolution (0x6005:1 = resolution in nm)
  EncoderNodeIdentity identity;
  std::uint8_t transmission_type = 1;  // 0x1800:2 at power-on
  std::uint16_t heartbeat_ms = 0;      // 0x1017 at power-on (0: no heartbeat)
  bool auto_start = false;             // boots into operational itself (no NMT master needed)
};

class EncoderNode {
 public:
  explicit EncoderNode(EncoderNodeSettings settings);

  // Powers on at t_ns (boot-up message; pre-operational, or operational with auto_start).
  void power_on(std::int64_t t_ns, std::vector<can_frame>& out);
  // A frame from the bus: NMT commands and SDO requests to this node are acted on.
  void receive(const can_frame& frame, std::int64_t t_ns, std::vector<can_frame>& out);
  // Heartbeats due, the end of a power-off or a mute.
  void tick(std::int64_t t_ns, std::vector<can_frame>& out);
  [[nodiscard]] std::int64_t next_deadline() const noexcept;
  // A SYNC: whether TPDO1 goes out for it (operational, synchronous, its n-th SYNC, powered, not muted).
  bool on_sync() noexcept;
  // The position value (0x6004) the node has now.
  void set_count(std::uint32_t count) noexcept { count_ = count; }

  // Faults. Power off for down_ns (nothing sent or heard), then power on again (boot-up).
  void reboot(std::int64_t t_ns, std::int64_t down_ns);
  // Deaf and mute for mute_ns (a connector that came loose): no heartbeat, PDO or SDO answer; then it
  // carries on in the same NMT state and reports EMCY 0x8140 (recovered from bus off).
  void mute(std::int64_t t_ns, std::int64_t mute_ns);
  // Every SDO request is aborted with `code` (0: answered again).
  void set_sdo_abort(std::uint32_t code) noexcept { sdo_abort_ = code; }
  // Another device answers under this node-ID: identity of the node from now on (and after reboots).
  void set_identity(const EncoderNodeIdentity& identity) noexcept { settings_.identity = identity; }
  // An EMCY now (error register kept in 0x1001; error code 0 = error reset clears it).
  void emcy(std::uint16_t error_code, std::uint8_t error_register, std::vector<can_frame>& out);

  [[nodiscard]] drivers::can::NmtState state() const noexcept { return state_; }
  [[nodiscard]] bool powered() const noexcept { return powered_; }
  [[nodiscard]] bool muted(std::int64_t t_ns) const noexcept { return t_ns < mute_until_ns_; }
  [[nodiscard]] std::uint8_t node_id() const noexcept { return settings_.scale.node_id; }
  [[nodiscard]] std::uint8_t transmission_type() const noexcept { return tx_type_; }
  [[nodiscard]] std::uint16_t heartbeat_ms() const noexcept { return heartbeat_ms_; }

 private:
  void restore_power_on_values();
  void serve_sdo(const can_frame& frame, std::int64_t t_ns, std::vector<can_frame>& out);
  void boot(std::int64_t t_ns, std::vector<can_frame>& out);

  EncoderNodeSettings settings_;
  bool powered_ = false;
  std::int64_t power_on_at_ns_ = 0;  // off: powers on then (0: stays off)
  std::int64_t mute_until_ns_ = 0;
  bool report_recovery_ = false;  // an EMCY 0x8140 when the mute ends
  drivers::can::NmtState state_ = drivers::can::NmtState::pre_operational;
  std::uint8_t tx_type_ = 1;
  std::uint16_t heartbeat_ms_ = 0;
  std::uint8_t error_register_ = 0;
  std::int64_t next_heartbeat_ns_ = 0;
  std::uint32_t sync_count_ = 0;
  std::uint32_t count_ = 0;
  std::uint32_t sdo_abort_ = 0;
};

}  // namespace guideway::simulators::emulators
