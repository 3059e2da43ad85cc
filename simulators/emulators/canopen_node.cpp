// One emulated CANopen encoder node (canopen_node.hpp): boot-up, NMT, heartbeat, SDO and TPDOs on SYNC, as a real one
// behaves.
#include "simulators/emulators/canopen_node.hpp"

#include <climits>
#include <cmath>

namespace guideway::simulators::emulators {

namespace can = drivers::can;

EncoderNode::EncoderNode(EncoderNodeSettings settings) : settings_(std::move(settings)) {
  if (settings_.identity.serial_number == 0) settings_.identity.serial_number = 1000u + settings_.scale.node_id;
  restore_power_on_values();
}

void EncoderNode::restore_power_on_values() {
  tx_type_ = settings_.transmission_type;
  heartbeat_ms_ = settings_.heartbeat_ms;
  error_register_ = 0;
  sync_count_ = 0;
}

void EncoderNode::boot(std::int64_t t_ns, std::vector<can_frame>& out) {
  restore_power_on_values();
  out.push_back(can::make_heartbeat(node_id(), can::NmtState::boot_up));
  state_ = settings_.auto_start ? can::NmtState::operational : can::NmtState::pre_operational;
  next_heartbeat_ns_ = t_ns + static_cast<std::int64_t>(heartbeat_ms_) * 1'000'000;
}

void EncoderNode::power_on(std::int64_t t_ns, std::vector<can_frame>& out) {
  powered_ = true;
  power_on_at_ns_ = 0;
  boot(t_ns, out);
}

void EncoderNode::reboot(std::int64_t t_ns, std::int64_t down_ns) {
  powered_ = false;
  power_on_at_ns_ = t_ns + std::max<std::int64_t>(down_ns, 1);
}

void EncoderNode::mute(std::int64_t t_ns, std::int64_t mute_ns) {
  mute_until_ns_ = t_ns + mute_ns;
  report_recovery_ = true;
}

void EncoderNode::emcy(std::uint16_t error_code, std::uint8_t error_register, std::vector<can_frame>& out) {
  error_register_ = error_code == 0 ? 0 : error_register;
  if (!powered_) return;
  can::Emcy e;
  e.error_code = error_code;
  e.error_register = error_register_;
  out.push_back(can::make_emcy(node_id(), e));
}

bool EncoderNode::on_sync() noexcept {
  if (!powered_ || mute_until_ns_ > 0) return false;  // muted: the emulator clears the mute in tick()
  if (state_ != can::NmtState::operational) return false;
  if (tx_type_ == 0) return true;    // acyclic: the emulator's encoders move all the time
  if (tx_type_ > 240) return false;  // event-driven or on request: nothing on SYNC
  ++sync_count_;
  if (sync_count_ < tx_type_) return false;
  sync_count_ = 0;
  return true;
}

void EncoderNode::tick(std::int64_t t_ns, std::vector<can_frame>& out) {
  if (!powered_) {
    if (power_on_at_ns_ != 0 && t_ns >= power_on_at_ns_) power_on(t_ns, out);
    return;
  }
  if (mute_until_ns_ > 0) {
    if (t_ns < mute_until_ns_) return;
    mute_until_ns_ = 0;
    if (report_recovery_) {
      report_recovery_ = false;
      emcy(0x8140, 0x11, out);  // recovered from bus off: generic + communication
    }
    next_heartbeat_ns_ = t_ns;
  }
  if (heartbeat_ms_ == 0) return;
  const std::int64_t period = static_cast<std::int64_t>(heartbeat_ms_) * 1'000'000;
  if (t_ns >= next_heartbeat_ns_) {
    out.push_back(can::make_heartbeat(node_id(), state_));
    next_heartbeat_ns_ += period;
    if (next_heartbeat_ns_ <= t_ns) next_heartbeat_ns_ = t_ns + period;  // held up: no burst of old heartbeats
  }
}

std::int64_t EncoderNode::next_deadline() const noexcept {
  if (!powered_) return power_on_at_ns_ != 0 ? power_on_at_ns_ : INT64_MAX;
  if (mute_until_ns_ > 0) return mute_until_ns_;
  return heartbeat_ms_ > 0 ? next_heartbeat_ns_ : INT64_MAX;
}

void EncoderNode::receive(const can_frame& f, std::int64_t t_ns, std::vector<can_frame>& out) {
  if (!powered_ || mute_until_ns_ > 0) return;
  can::NmtCommand command;
  std::uint8_t target = 0;
  if (can::parse_nmt_command(f, command, target)) {
    if (target != 0 && target != node_id()) return;
    switch (command) {
      case can::NmtCommand::start:
        state_ = can::NmtState::operational;
        break;
      case can::NmtCommand::stop:
        state_ = can::NmtState::stopped;
        break;
      case can::NmtCommand::enter_pre_operational:
        state_ = can::NmtState::pre_operational;
        break;
      case can::NmtCommand::reset_node:
      case can::NmtCommand::reset_communication:
        boot(t_ns, out);
        break;
    }
    return;
  }
  if (can::node_of(f, can::rsdo_cob_base) == node_id()) serve_sdo(f, t_ns, out);
}

void EncoderNode::serve_sdo(const can_frame& f, std::int64_t t_ns, std::vector<can_frame>& out) {
  if (state_ == can::NmtState::stopped) return;  // no SDO in stopped (CiA 301)
  const can::SdoMessage m = can::parse_sdo_request(f);
  const std::uint8_t id = node_id();
  const auto abort = [&](std::uint32_t code) { out.push_back(can::make_sdo_abort(id, m.address, code, false)); };
  if (m.kind == can::SdoKind::bad || m.kind == can::SdoKind::abort) return;
  if (m.kind == can::SdoKind::unsupported) return abort(can::sdo_abort_command);
  if (sdo_abort_ != 0) return abort(sdo_abort_);
  struct Entry {
    bool found = false;
    std::uint32_t value = 0;
    std::uint8_t size = 0;
    bool writable = false;
  };
  const auto resolution_nm = static_cast<std::uint32_t>(std::llround(settings_.scale.resolution_m * 1e9));
  Entry e;
  bool index_exists = true;
  const std::uint16_t idx = m.address.index;
  const std::uint8_t sub = m.address.sub;
  const auto entry = [&](std::uint32_t v, std::uint8_t size, bool writable = false) { e = {true, v, size, writable}; };
  switch (idx) {
    case 0x1000:
      if (sub == 0) entry(406, 4);
      break;  // device type: profile 406 in the low word
    case 0x1001:
      if (sub == 0) entry(error_register_, 1);
      break;
    case 0x1017:
      if (sub == 0) entry(heartbeat_ms_, 2, true);
      break;
    case 0x1018:
      if (sub == 0) entry(4, 1);
      if (sub == 1) entry(settings_.identity.vendor_id, 4);
      if (sub == 2) entry(settings_.identity.product_code, 4);
      if (sub == 3) entry(settings_.identity.revision_number, 4);
      if (sub == 4) entry(settings_.identity.serial_number, 4);
      break;
    case 0x1800:
      if (sub == 0) entry(2, 1);
      if (sub == 1) entry(drivers::dbb::tpdo1_cob_base + id, 4);
      if (sub == 2) entry(tx_type_, 1, true);
      break;
    case 0x6004:
      if (sub == 0) entry(count_, 4);
      break;
    case 0x6005:
      if (sub == 0) entry(1, 1);
      if (sub == 1) entry(resolution_nm, 4);
      break;
    default:
      index_exists = false;
  }
  if (!e.found) return abort(index_exists ? can::sdo_abort_no_sub : can::sdo_abort_no_object);
  if (m.kind == can::SdoKind::upload_request) {
    out.push_back(can::make_sdo_upload_response(id, m.address, e.value, e.size));
    return;
  }
  if (!e.writable) return abort(can::sdo_abort_write_read_only);
  if (m.size != 0 && m.size != e.size) return abort(can::sdo_abort_length);
  const std::uint32_t v = e.size < 4 ? m.value & ((1u << (8 * e.size)) - 1u) : m.value;
  if (idx == 0x1800) {
    if (v >= 241 && v <= 251) return abort(can::sdo_abort_value);  // reserved transmission types
    tx_type_ = static_cast<std::uint8_t>(v);
    sync_count_ = 0;
  } else if (idx == 0x1017) {
    heartbeat_ms_ = static_cast<std::uint16_t>(v);
    next_heartbeat_ns_ = t_ns;  // the producer starts at once
  }
  out.push_back(can::make_sdo_download_response(id, m.address));
}

}  // namespace guideway::simulators::emulators
