// The CANopen network management of a dbb-can bus (dbb_network.hpp): each node checked, started and watched; pure, no
// I/O.
#include "drivers/dbb/dbb_network.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>

namespace guideway::drivers::dbb {

namespace {

constexpr std::uint8_t tx_type_every_sync = 1;  // TPDO transmission type: synchronous, every SYNC

std::string hex32(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08X", v);
  return buf;
}

std::string tx_type_words(std::uint32_t t) {
  if (t == 0) return "synchronous acyclic (only when the value changed)";
  if (t == 1) return "synchronous, every SYNC";
  if (t <= 240) return "synchronous, every " + std::to_string(t) + " SYNCs";
  if (t == 252 || t == 253) return "on remote request only";
  if (t == 254 || t == 255) return "event-driven";
  return "reserved";
}

const char* step_object(int step) {
  static const char* names[] = {"identity: vendor-ID",
                                "identity: product code",
                                "identity: revision number",
                                "identity: serial number",
                                "linear encoder measuring step",
                                "TPDO1 COB-ID",
                                "TPDO1 transmission type",
                                "TPDO1 transmission type",
                                "TPDO1 transmission type",
                                "producer heartbeat time",
                                "producer heartbeat time",
                                "producer heartbeat time",
                                ""};
  return names[step];
}

std::int64_t ms_to_ns(std::int64_t ms) { return ms * 1'000'000; }

}  // namespace

EncoderNetwork::EncoderNetwork(std::vector<EncoderScale> encoders, std::vector<NodeExpectation> expect,
                               NetworkSettings settings)
    : settings_(settings) {
  for (std::size_t i = 0; i < encoders.size(); ++i) {
    Node n;
    n.scale = std::move(encoders[i]);
    if (i < expect.size()) n.expect = expect[i];
    nodes_.push_back(std::move(n));
  }
}

std::string EncoderNetwork::node_name(std::size_t i) const {
  return "node " + std::to_string(nodes_.at(i).scale.node_id) + " (" + nodes_.at(i).scale.channel + ")";
}

int EncoderNetwork::index_of(std::uint8_t node) const noexcept {
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (nodes_[i].scale.node_id == node) return static_cast<int>(i);
  return -1;
}

std::int64_t EncoderNetwork::heartbeat_timeout_ns(const Node& n) const noexcept {
  return ms_to_ns(n.expect.heartbeat_timeout_ms);
}

void EncoderNetwork::event(std::string name, std::string reason, bool warning) {
  if (events_.size() >= 256) events_.erase(events_.begin());  // the caller takes them at every frame batch
  events_.push_back({std::move(name), std::move(reason), warning});
}

void EncoderNetwork::connected(std::int64_t t_ns) {
  connected_ns_ = t_ns;
  first_round_ = true;
  for (Node& n : nodes_) {
    Node fresh;
    fresh.scale = n.scale;
    fresh.expect = n.expect;
    fresh.last_heartbeat_ns = t_ns;  // monitored from the connection on: a node never heard of is named too
    fresh.last_pdo_ns = t_ns;
    fresh.instrument_warning = n.instrument_warning;  // until the node's check says otherwise
    n = std::move(fresh);
  }
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    if (settings_.sdo_checks) {
      start_check(i, t_ns);
    } else if (!settings_.manage_nmt) {
      nodes_[i].phase = Phase::waiting;
    }
  }
  if (!settings_.sdo_checks && settings_.manage_nmt) start_nodes_ready(t_ns);
  changed();
}

can::SdoAddress EncoderNetwork::address_of(Step step) const noexcept {
  switch (step) {
    case Step::vendor:
      return {0x1018, 1};
    case Step::product:
      return {0x1018, 2};
    case Step::revision:
      return {0x1018, 3};
    case Step::serial:
      return {0x1018, 4};
    case Step::resolution:
      return {0x6005, 1};
    case Step::tpdo_cob_id:
      return {0x1800, 1};
    case Step::tx_type:
    case Step::tx_type_write:
    case Step::tx_type_verify:
      return {0x1800, 2};
    case Step::heartbeat:
    case Step::heartbeat_write:
    case Step::heartbeat_verify:
      return {0x1017, 0};
    case Step::done:
      break;
  }
  return {};
}

void EncoderNetwork::start_check(std::size_t i, std::int64_t t_ns) {
  Node& n = nodes_[i];
  n.phase = Phase::checking;
  n.step = Step::vendor;
  n.failure.clear();
  n.configured.clear();
  n.identity = {};
  n.sdo_tries = 0;
  send_step(i, t_ns);
  changed();
}

void EncoderNetwork::send_step(std::size_t i, std::int64_t t_ns) {
  Node& n = nodes_[i];
  // Steps that do not apply are passed over.
  if (n.step == Step::resolution && !n.expect.check_resolution) n.step = Step::tpdo_cob_id;
  if (n.step == Step::heartbeat && settings_.heartbeat_ms <= 0) n.step = Step::done;
  if (n.step == Step::done) {
    n.sdo_pending = false;
    checked(i, t_ns);
    return;
  }
  const can::SdoAddress a = address_of(n.step);
  if (n.step == Step::tx_type_write) {
    outgoing_.push_back(can::make_sdo_download_request(n.scale.node_id, a, tx_type_every_sync, 1));
  } else if (n.step == Step::heartbeat_write) {
    outgoing_.push_back(
        can::make_sdo_download_request(n.scale.node_id, a, static_cast<std::uint32_t>(settings_.heartbeat_ms), 2));
  } else {
    outgoing_.push_back(can::make_sdo_upload_request(n.scale.node_id, a));
  }
  n.sdo_pending = true;
  ++n.sdo_tries;
  n.sdo_deadline_ns = t_ns + ms_to_ns(settings_.sdo_timeout_ms);
}

void EncoderNetwork::step_done(std::size_t i, std::int64_t t_ns) {
  Node& n = nodes_[i];
  n.sdo_pending = false;
  n.sdo_tries = 0;
  n.step = static_cast<Step>(static_cast<int>(n.step) + 1);
  // A write follows a read only when the value must change (on_sdo says so) and is verified by reading.
  if (n.step == Step::tx_type_write && n.configured.empty()) n.step = Step::heartbeat;
  if (n.step == Step::heartbeat_write) n.step = Step::done;  // the heartbeat write is entered from on_sdo
  send_step(i, t_ns);
}

void EncoderNetwork::fail(std::size_t i, std::string why, std::int64_t t_ns, bool absent) {
  Node& n = nodes_[i];
  n.phase = Phase::failed;
  n.absent = absent;
  n.sdo_pending = false;
  n.failure = node_name(i) + ": " + why;
  n.retry_at_ns = t_ns + ms_to_ns(settings_.node_retry_ms);
  ++counters_.node_check_failures;
  event("node_check_failed",
        n.failure + " (not started; checked again in " + std::to_string(settings_.node_retry_ms) + " ms)");
  changed();
  start_nodes_ready(t_ns);
}

void EncoderNetwork::checked(std::size_t i, std::int64_t t_ns) {
  Node& n = nodes_[i];
  std::string s = node_name(i) + ":";
  const auto field = [&](const char* what, const std::optional<std::uint32_t>& v, bool hex) {
    s += std::string(" ") + what + " " + (v ? (hex ? hex32(*v) : std::to_string(*v)) : std::string("(none)")) + ",";
  };
  field("vendor-ID", n.identity.vendor_id, true);
  field("product code", n.identity.product_code, true);
  field("revision", n.identity.revision_number, true);
  field("serial number", n.identity.serial_number, false);
  s.back() = ';';
  if (n.expect.check_resolution) {
    char res[48];
    std::snprintf(res, sizeof res, " %g nm per count;", n.scale.resolution_m * 1e9);
    s += res;
  }
  s += " TPDO1 synchronous";
  if (settings_.heartbeat_ms > 0) s += "; heartbeat every " + std::to_string(settings_.heartbeat_ms) + " ms";
  if (!n.configured.empty()) s += " (" + n.configured + ")";
  s += settings_.manage_nmt ? "; starting it" : "; waiting for the NMT master to start it";
  event("node_checked", s, false);
  compare_instrument_serial(i);
  n.step = Step::done;
  if (!settings_.manage_nmt) {
    n.phase = Phase::waiting;
    changed();
    return;
  }
  start_nodes_ready(t_ns);
}

void EncoderNetwork::compare_instrument_serial(std::size_t i) {
  Node& n = nodes_[i];
  if (!n.expect.instrument_serial) return;
  const std::uint32_t want = *n.expect.instrument_serial;
  std::string warning;
  if (!n.identity.serial_number) {
    warning = node_name(i) + " has no serial number (0x1018:4): the device's serial " + std::to_string(want) +
              " cannot be confirmed";
  } else if (*n.identity.serial_number != want) {
    warning = node_name(i) + " reports serial number " + std::to_string(*n.identity.serial_number) +
              " (0x1018:4), the device's serial is " + std::to_string(want) +
              ": not the instrument the configuration and its calibration name";
  }
  if (warning != n.instrument_warning) {
    n.instrument_warning = warning;
    changed();
  }
  if (!warning.empty())
    event("instrument_serial_mismatch", warning + " (measuring anyway; check the instrument or its serial)");
}

std::vector<std::string> EncoderNetwork::warnings() const {
  std::vector<std::string> out;
  for (const Node& n : nodes_)
    if (!n.instrument_warning.empty()) out.push_back(n.instrument_warning);
  return out;
}

void EncoderNetwork::start_nodes_ready(std::int64_t t_ns) {
  if (!settings_.manage_nmt) return;
  if (first_round_) {
    // Started together once every node's check is over, so the first cycles are complete ones.
    for (const Node& n : nodes_)
      if (settings_.sdo_checks && n.phase == Phase::checking && n.step != Step::done) return;
    first_round_ = false;
    for (std::size_t i = 0; i < nodes_.size(); ++i) {
      const Node& n = nodes_[i];
      if (n.phase != Phase::failed && (!settings_.sdo_checks || n.step == Step::done)) send_start(i, t_ns);
    }
    return;
  }
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (nodes_[i].phase == Phase::checking && nodes_[i].step == Step::done) send_start(i, t_ns);
}

void EncoderNetwork::send_start(std::size_t i, std::int64_t t_ns) {
  Node& n = nodes_[i];
  outgoing_.push_back(can::make_nmt_command(can::NmtCommand::start, n.scale.node_id));
  ++counters_.nmt_starts;
  n.phase = Phase::starting;
  n.started_at_ns = t_ns;
  changed();
}

void EncoderNetwork::on_sdo(std::size_t i, const can::SdoMessage& m, std::int64_t t_ns) {
  Node& n = nodes_[i];
  if (n.phase != Phase::checking || !n.sdo_pending) return;  // late, or not ours
  const can::SdoAddress want = address_of(n.step);
  if (m.kind != can::SdoKind::unsupported && (m.address.index != want.index || m.address.sub != want.sub)) {
    return;  // an answer to an earlier request (one that timed out): the current one may still come
  }
  const std::string object = can::to_string(want) + " (" + step_object(static_cast<int>(n.step)) + ")";
  const bool writing = n.step == Step::tx_type_write || n.step == Step::heartbeat_write;
  const std::string transfer = std::string(writing ? "SDO download to " : "SDO upload of ") + object;
  switch (m.kind) {
    case can::SdoKind::abort: {
      ++counters_.sdo_aborts;
      const bool optional_identity = (n.step == Step::product && !n.expect.product_code) ||
                                     (n.step == Step::revision && !n.expect.revision_number) ||
                                     (n.step == Step::serial && !n.expect.serial_number);
      if (optional_identity && (m.abort_code == can::sdo_abort_no_sub || m.abort_code == can::sdo_abort_no_object)) {
        step_done(i, t_ns);  // sub-indices 2..4 of the identity are optional (CiA 301)
        return;
      }
      char code[16];
      std::snprintf(code, sizeof code, "0x%08X", m.abort_code);
      std::string why =
          transfer + " aborted by the node: " + code + " " + std::string(can::sdo_abort_text(m.abort_code));
      if (n.step == Step::resolution &&
          (m.abort_code == can::sdo_abort_no_sub || m.abort_code == can::sdo_abort_no_object))
        why += " (a CiA 406 linear encoder has it; for one without, set check_resolution = false)";
      fail(i, why, t_ns);
      return;
    }
    case can::SdoKind::unsupported:
      outgoing_.push_back(can::make_sdo_abort(n.scale.node_id, want, can::sdo_abort_command, true));
      fail(i,
           transfer + ": the node answered with a segmented or block transfer (expedited expected for a 4-byte object)",
           t_ns);
      return;
    case can::SdoKind::download_response:
      if (!writing) break;
      step_done(i, t_ns);
      return;
    case can::SdoKind::upload_response:
      if (writing) break;
      break;
    default:
      break;
  }
  if (m.kind != can::SdoKind::upload_response || writing) {
    fail(i, transfer + ": unexpected SDO answer", t_ns);
    return;
  }
  const std::uint32_t v = m.value;
  const auto compare_identity = [&](std::optional<std::uint32_t>& got, const std::optional<std::uint32_t>& want_v,
                                    const char* key, bool hex) {
    got = v;
    if (want_v && *want_v != v) {
      fail(i,
           object + " is " + (hex ? hex32(v) : std::to_string(v)) + ", configured " + key + " = " +
               (hex ? hex32(*want_v) : std::to_string(*want_v)) + ": not the node this encoder table describes",
           t_ns);
      return false;
    }
    return true;
  };
  switch (n.step) {
    case Step::vendor:
      if (!compare_identity(n.identity.vendor_id, n.expect.vendor_id, "vendor_id", true)) return;
      break;
    case Step::product:
      if (!compare_identity(n.identity.product_code, n.expect.product_code, "product_code", true)) return;
      break;
    case Step::revision:
      if (!compare_identity(n.identity.revision_number, n.expect.revision_number, "revision_number", true)) return;
      break;
    case Step::serial:
      if (!compare_identity(n.identity.serial_number, n.expect.serial_number, "serial_number", false)) return;
      break;
    case Step::resolution: {
      const double want_nm = n.scale.resolution_m * 1e9;
      if (std::abs(static_cast<double>(v) - want_nm) > 1e-9 * want_nm) {
        char buf[160];
        std::snprintf(buf, sizeof buf, " is %u nm per count, configured resolution_nm = %g", v, want_nm);
        fail(i, object + buf, t_ns);
        return;
      }
      break;
    }
    case Step::tpdo_cob_id: {
      const std::uint32_t expected = tpdo1_cob_base + n.scale.node_id;
      if (v & 0x80000000u) {
        fail(i, object + " is " + hex32(v) + ": TPDO1 is disabled (bit 31 set)", t_ns);
        return;
      }
      if ((v & 0x20000000u) || (v & 0x7FFu) != expected) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "0x%03X", expected);
        fail(i, object + " is " + hex32(v) + ": the driver reads TPDO1 on 0x180 + node-ID = " + buf, t_ns);
        return;
      }
      break;
    }
    case Step::tx_type:
      if (v != tx_type_every_sync) {
        if (settings_.configure_nodes) {
          n.configured = "TPDO1 transmission type was " + std::to_string(v) + ", set to 1 by Guideway";
          break;  // step_done moves on to the write
        }
        fail(i,
             object + " is " + std::to_string(v) + " (" + tx_type_words(v) +
                 "), needs 1 (synchronous, every SYNC): set it on the node or allow configure_nodes = true",
             t_ns);
        return;
      }
      break;
    case Step::tx_type_verify:
      if (v != tx_type_every_sync) {
        fail(i, object + " reads " + std::to_string(v) + " after Guideway wrote 1 (the node did not take it)", t_ns);
        return;
      }
      break;
    case Step::heartbeat:
      if (static_cast<std::int64_t>(v) != settings_.heartbeat_ms) {
        if (settings_.configure_nodes) {
          n.configured += std::string(n.configured.empty() ? "" : ", ") + "heartbeat time was " + std::to_string(v) +
                          " ms, set by Guideway";
          n.sdo_pending = false;
          n.sdo_tries = 0;
          n.step = Step::heartbeat_write;
          send_step(i, t_ns);
          return;
        }
        fail(i,
             object + " is " + std::to_string(v) + " ms, configured heartbeat_ms = " +
                 std::to_string(settings_.heartbeat_ms) + ": set it on the node or allow configure_nodes = true",
             t_ns);
        return;
      }
      break;  // nothing to write: step_done ends the check
    case Step::heartbeat_verify:
      if (static_cast<std::int64_t>(v) != settings_.heartbeat_ms) {
        fail(i,
             object + " reads " + std::to_string(v) + " ms after Guideway wrote " +
                 std::to_string(settings_.heartbeat_ms),
             t_ns);
        return;
      }
      break;
    default:
      break;
  }
  step_done(i, t_ns);
}

void EncoderNetwork::on_boot(std::size_t i, std::int64_t t_ns) {
  Node& n = nodes_[i];
  ++counters_.boot_ups;
  n.was_down = true;
  n.rebooted = true;
  n.missed_cycles = 0;
  n.silent = false;
  n.sdo_pending = false;
  std::string what = node_name(i) + " booted (boot-up message)";
  if (settings_.manage_nmt) {
    what += ": pre-operational, no PDOs until started; ";
    what += settings_.sdo_checks ? "checking it by SDO and starting it" : "starting it";
  } else {
    what += ": no PDOs until the NMT master (or the node itself) starts it";
    if (settings_.sdo_checks) what += "; checking it by SDO";
  }
  event("node_boot", what);
  if (settings_.sdo_checks) {
    start_check(i, t_ns);
  } else if (settings_.manage_nmt) {
    send_start(i, t_ns);
  } else {
    n.phase = Phase::waiting;
  }
  changed();
}

void EncoderNetwork::on_heartbeat(std::size_t i, const can::Heartbeat& h, std::int64_t t_ns) {
  Node& n = nodes_[i];
  n.last_heartbeat_ns = t_ns;
  if (n.heartbeat_lost) {
    n.heartbeat_lost = false;
    changed();
    if (n.was_down && n.phase == Phase::operational && !n.silent) {
      n.was_down = false;
      event("node_back", node_name(i) + ": heartbeat again (" + std::string(can::to_string(h.state)) + ")", false);
    }
  }
  switch (h.state) {
    case can::NmtState::boot_up:
      on_boot(i, t_ns);
      return;
    case can::NmtState::operational:
      if (n.phase == Phase::starting || n.phase == Phase::waiting || n.phase == Phase::unknown ||
          n.phase == Phase::stopped) {
        n.phase = Phase::operational;
        n.last_pdo_ns = std::max(n.last_pdo_ns, t_ns);  // its PDOs are due from now on
        changed();
      }
      return;
    case can::NmtState::pre_operational:
      if (n.phase == Phase::operational) {
        // It left operational without a boot-up message we saw (enter pre-operational, a reset heard only in part).
        n.was_down = true;
        event("node_lost", node_name(i) + " is pre-operational again (heartbeat): it sends no PDOs" +
                               std::string(settings_.manage_nmt ? "; starting it again" : ""));
        if (settings_.manage_nmt) {
          if (settings_.sdo_checks)
            start_check(i, t_ns);
          else
            send_start(i, t_ns);
        } else {
          n.phase = Phase::waiting;
        }
        changed();
      } else if (n.phase == Phase::starting && t_ns - n.started_at_ns > 2 * ms_to_ns(settings_.sdo_timeout_ms)) {
        send_start(i, t_ns);  // the start command was lost
      } else if (n.phase == Phase::unknown) {
        n.phase = Phase::waiting;
        changed();
      }
      return;
    case can::NmtState::stopped:
      if (n.phase != Phase::stopped && n.phase != Phase::checking && n.phase != Phase::failed) {
        n.phase = Phase::stopped;
        n.was_down = true;
        event("node_lost", node_name(i) + " was stopped (NMT stop from another master): it sends no PDOs");
        changed();
      }
      return;
  }
}

void EncoderNetwork::mark_silent(std::size_t i, const std::string& why) {
  Node& n = nodes_[i];
  n.silent = true;
  n.was_down = true;
  n.silent_why = why;
  event("node_lost", node_name(i) + ": " + why);
  changed();
}

void EncoderNetwork::node_delivers(std::size_t i, std::int64_t t_ns) {
  Node& n = nodes_[i];
  n.last_pdo_ns = t_ns;
  n.missed_cycles = 0;
  const bool had_gap = n.silent || n.rebooted;
  if (n.silent) {
    n.silent = false;
    changed();
  }
  if (n.phase == Phase::starting || n.phase == Phase::waiting || n.phase == Phase::unknown ||
      n.phase == Phase::stopped) {
    n.phase = Phase::operational;  // a PDO: it is operational, whoever started it
    changed();
  }
  if (n.phase == Phase::operational && n.was_down && !n.heartbeat_lost) {
    n.was_down = false;
    n.rebooted = false;
    if (had_gap) gap_ = true;
    event("node_back", node_name(i) + ": its PDOs arrive again", false);
  }
}

void EncoderNetwork::on_cycle(std::uint32_t present_mask, std::int64_t t_ns) {
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    Node& n = nodes_[i];
    if (present_mask & (1u << i)) {
      node_delivers(i, t_ns);
    } else if (n.phase == Phase::operational && !n.silent && ++n.missed_cycles >= settings_.silent_after_cycles) {
      mark_silent(i, "no PDO in the last " + std::to_string(settings_.silent_after_cycles) +
                         " cycles (its channel holds its last value; samples are flagged partial)");
    }
  }
}

EncoderNetwork::FrameUse EncoderNetwork::on_frame(const can_frame& f, std::int64_t t_ns) {
  if (f.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) return FrameUse::not_ours;
  const std::uint32_t id = f.can_id & CAN_SFF_MASK;
  if (id > can::heartbeat_cob_base && id < can::heartbeat_cob_base + 0x80) {
    const int i = index_of(static_cast<std::uint8_t>(id - can::heartbeat_cob_base));
    if (i < 0) return FrameUse::not_ours;
    can::Heartbeat h;
    if (!can::parse_heartbeat(f, h)) return FrameUse::bad;
    on_heartbeat(static_cast<std::size_t>(i), h, t_ns);
    return FrameUse::used;
  }
  if (id > can::emcy_cob_base && id < can::emcy_cob_base + 0x80) {
    const int i = index_of(static_cast<std::uint8_t>(id - can::emcy_cob_base));
    if (i < 0) return FrameUse::not_ours;
    std::uint8_t node = 0;
    can::Emcy e;
    if (!can::parse_emcy(f, node, e)) return FrameUse::bad;
    ++counters_.emcys;
    event("node_emcy", node_name(static_cast<std::size_t>(i)) + ": " + can::describe(e), e.error_code != 0);
    return FrameUse::used;
  }
  if (id > can::tsdo_cob_base && id < can::tsdo_cob_base + 0x80) {
    const int i = index_of(static_cast<std::uint8_t>(id - can::tsdo_cob_base));
    if (i < 0) return FrameUse::not_ours;
    const can::SdoMessage m = can::parse_sdo_response(f);
    if (m.kind == can::SdoKind::bad) return FrameUse::bad;
    on_sdo(static_cast<std::size_t>(i), m, t_ns);
    return FrameUse::used;
  }
  return FrameUse::not_ours;
}

void EncoderNetwork::tick(std::int64_t t_ns) {
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    Node& n = nodes_[i];
    if (n.phase == Phase::checking && n.sdo_pending && t_ns >= n.sdo_deadline_ns) {
      ++counters_.sdo_timeouts;
      if (n.sdo_tries < 2) {
        send_step(i, t_ns);  // once more: a frame can be lost
      } else {
        const bool writing = n.step == Step::tx_type_write || n.step == Step::heartbeat_write;
        fail(i,
             std::string("no answer to the SDO ") + (writing ? "download to " : "upload of ") +
                 can::to_string(address_of(n.step)) + " (" + step_object(static_cast<int>(n.step)) + ") within " +
                 std::to_string(settings_.sdo_timeout_ms) + " ms, twice (is node-ID " +
                 std::to_string(n.scale.node_id) + " on the bus and powered?)",
             t_ns, true);
      }
    }
    if (n.phase == Phase::failed && t_ns >= n.retry_at_ns) start_check(i, t_ns);
    const std::int64_t hb_timeout = heartbeat_timeout_ns(n);
    if (hb_timeout > 0 && !n.heartbeat_lost && t_ns - n.last_heartbeat_ns > hb_timeout) {
      n.heartbeat_lost = true;
      n.was_down = true;
      ++counters_.heartbeat_timeouts;
      event("node_lost", node_name(i) + ": no heartbeat for " + std::to_string(n.expect.heartbeat_timeout_ms) + " ms");
      changed();
    }
    const std::int64_t pdo_timeout = ms_to_ns(settings_.pdo_timeout_ms);
    if (n.phase == Phase::operational && !n.silent && t_ns - n.last_pdo_ns > pdo_timeout) {
      mark_silent(i, "no PDO for " + std::to_string(settings_.pdo_timeout_ms) + " ms");
    }
    if (n.phase == Phase::starting && settings_.manage_nmt && t_ns - n.started_at_ns > pdo_timeout) {
      send_start(i, t_ns);  // started, yet no sign of it: the command may have been lost
    }
  }
}

std::int64_t EncoderNetwork::next_deadline() const noexcept {
  std::int64_t next = INT64_MAX;
  const std::int64_t pdo_timeout = ms_to_ns(settings_.pdo_timeout_ms);
  for (const Node& n : nodes_) {
    if (n.phase == Phase::checking && n.sdo_pending) next = std::min(next, n.sdo_deadline_ns);
    if (n.phase == Phase::failed) next = std::min(next, n.retry_at_ns);
    const std::int64_t hb_timeout = heartbeat_timeout_ns(n);
    if (hb_timeout > 0 && !n.heartbeat_lost) next = std::min(next, n.last_heartbeat_ns + hb_timeout + 1);
    if (n.phase == Phase::operational && !n.silent) next = std::min(next, n.last_pdo_ns + pdo_timeout + 1);
    if (n.phase == Phase::starting && settings_.manage_nmt) next = std::min(next, n.started_at_ns + pdo_timeout + 1);
  }
  return next;
}

const NetworkHealth& EncoderNetwork::health() {
  if (health_of_version_ == version_) return health_;
  health_of_version_ = version_;
  struct Item {
    NetworkHealth::Level level;
    std::string text;
  };
  std::vector<Item> items;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const Node& n = nodes_[i];
    const std::string name = node_name(i);
    if (n.phase == Phase::failed) {
      items.push_back({n.absent ? NetworkHealth::Level::lost : NetworkHealth::Level::failed, n.failure});
    } else if (n.heartbeat_lost) {
      items.push_back({NetworkHealth::Level::lost,
                       name + ": no heartbeat for " + std::to_string(n.expect.heartbeat_timeout_ms) + " ms"});
    } else if (n.silent) {
      items.push_back({NetworkHealth::Level::lost, name + ": " + n.silent_why});
    } else if (n.phase == Phase::stopped) {
      items.push_back({NetworkHealth::Level::lost, name + " stopped by an NMT command: it sends no PDOs"});
    } else if (n.phase == Phase::unknown) {
      items.push_back({NetworkHealth::Level::starting, name + ": not heard from yet"});
    } else if (n.phase == Phase::checking) {
      items.push_back({NetworkHealth::Level::starting,
                       name + (n.rebooted ? " rebooted: checking it by SDO" : ": checking it by SDO")});
    } else if (n.phase == Phase::starting) {
      items.push_back(
          {NetworkHealth::Level::starting, name + (n.rebooted ? " rebooted: started (NMT), waiting for its PDOs"
                                                              : ": started (NMT), waiting for its PDOs")});
    } else if (n.phase == Phase::waiting) {
      items.push_back({NetworkHealth::Level::starting,
                       name + ": pre-operational, waiting for the NMT master to start it (nmt = \"listen\")"});
    }
  }
  std::stable_sort(items.begin(), items.end(), [](const Item& a, const Item& b) { return a.level > b.level; });
  health_.level = items.empty() ? NetworkHealth::Level::ok : items.front().level;
  health_.reason.clear();
  for (const Item& it : items) health_.reason += (health_.reason.empty() ? "" : "; ") + it.text;
  return health_;
}

}  // namespace guideway::drivers::dbb
