// CANopen (CiA 301) network services as pure frame encoders and decoders (canopen.hpp): NMT, heartbeat, EMCY, expedited
// SDO.
#include "drivers/can/canopen.hpp"

#include <cstdio>

namespace guideway::drivers::can {

namespace {

std::uint32_t data_u32(const can_frame& f, std::size_t at) noexcept {
  return static_cast<std::uint32_t>(f.data[at]) | static_cast<std::uint32_t>(f.data[at + 1]) << 8 |
         static_cast<std::uint32_t>(f.data[at + 2]) << 16 | static_cast<std::uint32_t>(f.data[at + 3]) << 24;
}

void put_u32(can_frame& f, std::size_t at, std::uint32_t v) noexcept {
  for (std::size_t i = 0; i < 4; ++i) f.data[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

can_frame sdo_frame(std::uint32_t cob_id, std::uint8_t command, SdoAddress a, std::uint32_t data) noexcept {
  can_frame f{};
  f.can_id = cob_id;
  f.can_dlc = 8;
  f.data[0] = command;
  f.data[1] = static_cast<std::uint8_t>(a.index & 0xFF);
  f.data[2] = static_cast<std::uint8_t>(a.index >> 8);
  f.data[3] = a.sub;
  put_u32(f, 4, data);
  return f;
}

// Expedited command byte: base | n << 2 | e | s, n = bytes of the four that hold no data.
std::uint8_t expedited_command(std::uint8_t base, std::uint8_t size) noexcept {
  if (size < 1 || size > 4) return static_cast<std::uint8_t>(base | 0x02);  // e = 1, s = 0: size not indicated
  return static_cast<std::uint8_t>(base | (4 - size) << 2 | 0x03);
}

std::uint32_t masked(std::uint32_t v, std::uint8_t size) noexcept {
  return size >= 1 && size < 4 ? v & ((1u << (8 * size)) - 1u) : v;
}

// An expedited initiate (download request or upload response): value and size from the command byte.
void read_expedited(const can_frame& f, SdoMessage& m) noexcept {
  const std::uint8_t c = f.data[0];
  m.size = (c & 0x01) ? static_cast<std::uint8_t>(4 - ((c >> 2) & 0x03)) : 0;
  m.value = masked(data_u32(f, 4), m.size);
}

SdoMessage parse_sdo_common(const can_frame& f, std::uint32_t cob_base) noexcept {
  SdoMessage m;
  m.node = node_of(f, cob_base);
  if (m.node == 0 || f.can_dlc != 8) return m;  // bad
  m.address.index = static_cast<std::uint16_t>(f.data[1] | f.data[2] << 8);
  m.address.sub = f.data[3];
  return m;
}

SdoMessage bad_sdo(std::uint8_t node) noexcept {
  SdoMessage m;
  m.node = node;
  return m;  // kind bad
}

}  // namespace

std::uint8_t node_of(const can_frame& f, std::uint32_t cob_base) noexcept {
  if (f.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) return 0;
  const std::uint32_t id = f.can_id & CAN_SFF_MASK;
  if (id <= cob_base || id >= cob_base + 0x80) return 0;
  return static_cast<std::uint8_t>(id - cob_base);
}

can_frame make_nmt_command(NmtCommand command, std::uint8_t node) noexcept {
  can_frame f{};
  f.can_id = nmt_cob_id;
  f.can_dlc = 2;
  f.data[0] = static_cast<std::uint8_t>(command);
  f.data[1] = node;
  return f;
}

bool parse_nmt_command(const can_frame& f, NmtCommand& command, std::uint8_t& node) noexcept {
  if (f.can_id != nmt_cob_id || f.can_dlc != 2 || f.data[1] > 127) return false;
  switch (f.data[0]) {
    case 0x01:
    case 0x02:
    case 0x80:
    case 0x81:
    case 0x82:
      command = static_cast<NmtCommand>(f.data[0]);
      node = f.data[1];
      return true;
    default:
      return false;
  }
}

std::string_view to_string(NmtCommand command) noexcept {
  switch (command) {
    case NmtCommand::start:
      return "start remote node";
    case NmtCommand::stop:
      return "stop remote node";
    case NmtCommand::enter_pre_operational:
      return "enter pre-operational";
    case NmtCommand::reset_node:
      return "reset node";
    case NmtCommand::reset_communication:
      return "reset communication";
  }
  return "unknown NMT command";
}

can_frame make_heartbeat(std::uint8_t node, NmtState state) noexcept {
  can_frame f{};
  f.can_id = heartbeat_cob_base + node;
  f.can_dlc = 1;
  f.data[0] = static_cast<std::uint8_t>(state);
  return f;
}

bool parse_heartbeat(const can_frame& f, Heartbeat& h) noexcept {
  h.node = node_of(f, heartbeat_cob_base);
  if (h.node == 0 || f.can_dlc != 1) return false;
  h.toggle = (f.data[0] & 0x80) != 0;
  if (f.data[0] == 0x80) return false;  // a toggled "boot-up": no node answers node guarding so
  switch (f.data[0] & 0x7F) {
    case 0x00:
    case 0x04:
    case 0x05:
    case 0x7F:
      h.state = static_cast<NmtState>(f.data[0] & 0x7F);
      return true;
    default:
      return false;
  }
}

std::string_view to_string(NmtState state) noexcept {
  switch (state) {
    case NmtState::boot_up:
      return "boot-up";
    case NmtState::stopped:
      return "stopped";
    case NmtState::operational:
      return "operational";
    case NmtState::pre_operational:
      return "pre-operational";
  }
  return "unknown NMT state";
}

can_frame make_emcy(std::uint8_t node, const Emcy& e) noexcept {
  can_frame f{};
  f.can_id = emcy_cob_base + node;
  f.can_dlc = 8;
  f.data[0] = static_cast<std::uint8_t>(e.error_code & 0xFF);
  f.data[1] = static_cast<std::uint8_t>(e.error_code >> 8);
  f.data[2] = e.error_register;
  for (std::size_t i = 0; i < 5; ++i) f.data[3 + i] = e.manufacturer[i];
  return f;
}

bool parse_emcy(const can_frame& f, std::uint8_t& node, Emcy& e) noexcept {
  node = node_of(f, emcy_cob_base);
  if (node == 0 || f.can_dlc < 2 || f.can_dlc > CAN_MAX_DLEN) return false;
  e = Emcy{};
  e.error_code = static_cast<std::uint16_t>(f.data[0] | f.data[1] << 8);
  if (f.can_dlc > 2) e.error_register = f.data[2];
  for (std::size_t i = 3; i < f.can_dlc; ++i) e.manufacturer[i - 3] = f.data[i];
  return true;
}

std::string_view emcy_error_text(std::uint16_t code) noexcept {
  // CiA 301's error codes: exact entries first, then the class of the high byte, then of the high nibble.
  struct Entry {
    std::uint16_t code;
    std::string_view text;
  };
  static constexpr Entry exact[] = {
      {0x0000, "error reset or no error"},
      {0x8110, "CAN overrun (objects lost)"},
      {0x8120, "CAN in error passive mode"},
      {0x8130, "life guard or heartbeat error"},
      {0x8140, "recovered from bus off"},
      {0x8150, "CAN-ID collision"},
      {0x8210, "PDO not processed due to length error"},
      {0x8220, "PDO length exceeded"},
      {0x8230, "DAM MPDO not processed, destination object not available"},
      {0x8240, "unexpected SYNC data length"},
      {0x8250, "RPDO timeout"},
  };
  static constexpr Entry by_high_byte[] = {
      {0x1000, "generic error"},
      {0x2100, "current, device input side"},
      {0x2200, "current inside the device"},
      {0x2300, "current, device output side"},
      {0x3100, "mains voltage"},
      {0x3200, "voltage inside the device"},
      {0x3300, "output voltage"},
      {0x4100, "ambient temperature"},
      {0x4200, "device temperature"},
      {0x5000, "device hardware"},
      {0x6100, "internal software"},
      {0x6200, "user software"},
      {0x6300, "data set"},
      {0x7000, "additional modules"},
      {0x8100, "communication"},
      {0x8200, "protocol error"},
      {0x9000, "external error"},
      {0xF000, "additional functions"},
      {0xFF00, "device specific"},
  };
  static constexpr Entry by_class[] = {
      {0x2000, "current"},         {0x3000, "voltage"},         {0x4000, "temperature"},
      {0x5000, "device hardware"}, {0x6000, "device software"}, {0x7000, "additional modules"},
      {0x8000, "monitoring"},
  };
  for (const auto& e : exact)
    if (e.code == code) return e.text;
  for (const auto& e : by_high_byte)
    if (e.code == (code & 0xFF00)) return e.text;
  for (const auto& e : by_class)
    if (e.code == (code & 0xF000)) return e.text;
  return "unknown error code";
}

std::string error_register_text(std::uint8_t r) {
  static constexpr std::string_view bits[8] = {"generic",       "current",        "voltage",  "temperature",
                                               "communication", "device profile", "reserved", "manufacturer"};
  if (r == 0) return "none";
  std::string out;
  for (int b = 0; b < 8; ++b) {
    if (!(r & (1u << b))) continue;
    if (!out.empty()) out += ", ";
    out += bits[b];
  }
  return out;
}

std::string describe(const Emcy& e) {
  char head[64];
  std::snprintf(head, sizeof head, "EMCY 0x%04X (", e.error_code);
  char reg[40];
  std::snprintf(reg, sizeof reg, "), error register 0x%02X (", e.error_register);
  std::string out = head;
  out += emcy_error_text(e.error_code);
  out += reg;
  out += error_register_text(e.error_register);
  out += ")";
  bool any = false;
  for (auto b : e.manufacturer) any |= b != 0;
  if (any) {
    char m[48];
    std::snprintf(m, sizeof m, ", manufacturer data %02X %02X %02X %02X %02X", e.manufacturer[0], e.manufacturer[1],
                  e.manufacturer[2], e.manufacturer[3], e.manufacturer[4]);
    out += m;
  }
  return out;
}

can_frame make_sdo_upload_request(std::uint8_t node, SdoAddress a) noexcept {
  return sdo_frame(rsdo_cob_base + node, 0x40, a, 0);
}

can_frame make_sdo_download_request(std::uint8_t node, SdoAddress a, std::uint32_t value, std::uint8_t size) noexcept {
  return sdo_frame(rsdo_cob_base + node, expedited_command(0x20, size), a, masked(value, size));
}

can_frame make_sdo_upload_response(std::uint8_t node, SdoAddress a, std::uint32_t value, std::uint8_t size) noexcept {
  return sdo_frame(tsdo_cob_base + node, expedited_command(0x40, size), a, masked(value, size));
}

can_frame make_sdo_download_response(std::uint8_t node, SdoAddress a) noexcept {
  return sdo_frame(tsdo_cob_base + node, 0x60, a, 0);
}

can_frame make_sdo_abort(std::uint8_t node, SdoAddress a, std::uint32_t code, bool to_server) noexcept {
  return sdo_frame((to_server ? rsdo_cob_base : tsdo_cob_base) + node, 0x80, a, code);
}

SdoMessage parse_sdo_request(const can_frame& f) noexcept {
  SdoMessage m = parse_sdo_common(f, rsdo_cob_base);
  if (m.node == 0 || f.can_dlc != 8) return bad_sdo(m.node);
  const std::uint8_t c = f.data[0];
  switch (c >> 5) {                                                            // client command specifier
    case 1:                                                                    // initiate download
      m.kind = (c & 0x02) ? SdoKind::download_request : SdoKind::unsupported;  // e = 0: segmented
      if (m.kind == SdoKind::download_request) read_expedited(f, m);
      break;
    case 2:
      m.kind = SdoKind::upload_request;
      break;
    case 4:
      m.kind = SdoKind::abort;
      m.abort_code = data_u32(f, 4);
      break;
    case 0:  // download segment
    case 3:  // upload segment
    case 5:  // block upload
    case 6:  // block download
      m.kind = SdoKind::unsupported;
      break;
    default:
      m.kind = SdoKind::bad;
  }
  return m;
}

SdoMessage parse_sdo_response(const can_frame& f) noexcept {
  SdoMessage m = parse_sdo_common(f, tsdo_cob_base);
  if (m.node == 0 || f.can_dlc != 8) return bad_sdo(m.node);
  const std::uint8_t c = f.data[0];
  switch (c >> 5) {                                                           // server command specifier
    case 2:                                                                   // initiate upload response
      m.kind = (c & 0x02) ? SdoKind::upload_response : SdoKind::unsupported;  // e = 0: segmented
      if (m.kind == SdoKind::upload_response) read_expedited(f, m);
      break;
    case 3:
      m.kind = SdoKind::download_response;
      break;
    case 4:
      m.kind = SdoKind::abort;
      m.abort_code = data_u32(f, 4);
      break;
    case 0:  // upload segment
    case 1:  // download segment
    case 5:  // block download
    case 6:  // block upload
      m.kind = SdoKind::unsupported;
      break;
    default:
      m.kind = SdoKind::bad;
  }
  return m;
}

std::string_view sdo_abort_text(std::uint32_t code) noexcept {
  struct Entry {
    std::uint32_t code;
    std::string_view text;
  };
  static constexpr Entry table[] = {
      {0x05030000, "toggle bit not alternated"},
      {0x05040000, "SDO protocol timed out"},
      {0x05040001, "client/server command specifier not valid or unknown"},
      {0x05040002, "invalid block size"},
      {0x05040003, "invalid sequence number"},
      {0x05040004, "CRC error"},
      {0x05040005, "out of memory"},
      {0x06010000, "unsupported access to an object"},
      {0x06010001, "attempt to read a write-only object"},
      {0x06010002, "attempt to write a read-only object"},
      {0x06020000, "object does not exist in the object dictionary"},
      {0x06040041, "object cannot be mapped to the PDO"},
      {0x06040042, "the number and length of the objects to be mapped would exceed the PDO length"},
      {0x06040043, "general parameter incompatibility"},
      {0x06040047, "general internal incompatibility in the device"},
      {0x06060000, "access failed due to a hardware error"},
      {0x06070010, "data type does not match, length of service parameter does not match"},
      {0x06070012, "data type does not match, length of service parameter too high"},
      {0x06070013, "data type does not match, length of service parameter too low"},
      {0x06090011, "sub-index does not exist"},
      {0x06090030, "invalid value for parameter"},
      {0x06090031, "value of parameter written too high"},
      {0x06090032, "value of parameter written too low"},
      {0x06090036, "maximum value is less than minimum value"},
      {0x060A0023, "resource not available: SDO connection"},
      {0x08000000, "general error"},
      {0x08000020, "data cannot be transferred or stored to the application"},
      {0x08000021, "data cannot be transferred or stored to the application because of local control"},
      {0x08000022, "data cannot be transferred or stored to the application because of the present device state"},
      {0x08000023, "object dictionary dynamic generation failed or no object dictionary is present"},
      {0x08000024, "no data available"},
  };
  for (const auto& e : table)
    if (e.code == code) return e.text;
  return "unknown abort code";
}

std::string to_string(SdoAddress a) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%04X:%u", a.index, static_cast<unsigned>(a.sub));
  return buf;
}

}  // namespace guideway::drivers::can
