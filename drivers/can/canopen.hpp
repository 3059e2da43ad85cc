#pragma once
// CANopen (CiA 301) network services as pure frame encoders and decoders: NMT node control, the NMT
// error control messages (boot-up and heartbeat), EMCY and expedited SDO, with the texts of the
// standard's error codes and abort codes. No I/O and no state, so the driver, the emulated nodes and
// the fuzz tests share them. COB-IDs are those of the pre-defined connection set (node-ID 1..127).

#include <linux/can.h>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace guideway::drivers::can {

inline constexpr std::uint32_t nmt_cob_id = 0x000;          // NMT node control, from the NMT master
inline constexpr std::uint32_t emcy_cob_base = 0x080;       // EMCY: 0x080 + node
inline constexpr std::uint32_t tsdo_cob_base = 0x580;       // SDO server -> client: 0x580 + node
inline constexpr std::uint32_t rsdo_cob_base = 0x600;       // SDO client -> server: 0x600 + node
inline constexpr std::uint32_t heartbeat_cob_base = 0x700;  // boot-up and heartbeat: 0x700 + node

// The standard identifier of a data frame of the given base for node (1..127), or 0 when the frame
// is not one: an extended or remote frame, another base, node 0.
std::uint8_t node_of(const can_frame& frame, std::uint32_t cob_base) noexcept;

// ---- NMT node control: COB-ID 0x000, two bytes: command specifier, node-ID (0 = every node).
enum class NmtCommand : std::uint8_t {
  start = 0x01,                  // start remote node -> operational
  stop = 0x02,                   // stop remote node -> stopped
  enter_pre_operational = 0x80,  // -> pre-operational
  reset_node = 0x81,             // application reset, then boot-up
  reset_communication = 0x82,    // communication reset, then boot-up
};
can_frame make_nmt_command(NmtCommand command, std::uint8_t node) noexcept;
// False when the frame is not a well-formed NMT command (wrong COB-ID, length, command or node-ID).
bool parse_nmt_command(const can_frame& frame, NmtCommand& command, std::uint8_t& node) noexcept;
std::string_view to_string(NmtCommand command) noexcept;

// ---- NMT error control: COB-ID 0x700 + node, one byte: the node's NMT state (0 = boot-up message).
enum class NmtState : std::uint8_t { boot_up = 0x00, stopped = 0x04, operational = 0x05, pre_operational = 0x7F };
can_frame make_heartbeat(std::uint8_t node, NmtState state) noexcept;
struct Heartbeat {
  std::uint8_t node = 0;
  NmtState state = NmtState::boot_up;
  bool toggle = false;  // bit 7: node guarding's toggle bit (a heartbeat sends 0)
};
// False when the frame is not one (node 0, DLC other than 1, an unknown state).
bool parse_heartbeat(const can_frame& frame, Heartbeat& heartbeat) noexcept;
std::string_view to_string(NmtState state) noexcept;

// ---- EMCY: COB-ID 0x080 + node, eight bytes: error code (UNSIGNED16), error register (object
// 0x1001), five manufacturer-specific bytes. Error code 0x0000 is "error reset": the error is gone.
struct Emcy {
  std::uint16_t error_code = 0;
  std::uint8_t error_register = 0;
  std::array<std::uint8_t, 5> manufacturer{};
};
can_frame make_emcy(std::uint8_t node, const Emcy& emcy) noexcept;
// Accepts DLC 2..8 (some nodes send short EMCYs; missing bytes read 0); false for DLC < 2.
bool parse_emcy(const can_frame& frame, std::uint8_t& node, Emcy& emcy) noexcept;
// The standard's meaning of an error code ("heartbeat error", "voltage", ...): the most specific
// entry of CiA 301's table that matches, down to its class ("device specific" for 0xFFxx).
std::string_view emcy_error_text(std::uint16_t error_code) noexcept;
// The set bits of the error register in words ("generic, communication"), "none" when 0.
std::string error_register_text(std::uint8_t error_register);
// One line: "EMCY 0x8130 (life guard or heartbeat error), error register 0x11 (generic, communication)".
std::string describe(const Emcy& emcy);

// ---- SDO, expedited transfers only (objects of at most 4 bytes). Client requests go to 0x600 +
// node, server responses come from 0x580 + node; every SDO frame has eight bytes: command byte,
// index (little-endian), sub-index, four data bytes.
struct SdoAddress {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
};
enum class SdoKind {
  upload_request,     // client: read index:sub
  download_request,   // client: write `value` (expedited, `size` bytes; 0 = size not indicated)
  upload_response,    // server: `value`, `size` bytes (0 = size not indicated)
  download_response,  // server: the write is done
  abort,              // either side: `abort_code`
  unsupported,        // a valid SDO frame of a service not supported here (segmented or block transfer)
  bad,                // not an SDO frame of this direction: wrong length, unknown command
};
struct SdoMessage {
  SdoKind kind = SdoKind::bad;
  std::uint8_t node = 0;
  SdoAddress address;
  std::uint32_t value = 0;
  std::uint8_t size = 0;  // 1..4 bytes of `value` that are meaningful, 0 when not indicated
  std::uint32_t abort_code = 0;
};
can_frame make_sdo_upload_request(std::uint8_t node, SdoAddress address) noexcept;
can_frame make_sdo_download_request(std::uint8_t node, SdoAddress address, std::uint32_t value,
                                    std::uint8_t size) noexcept;
can_frame make_sdo_upload_response(std::uint8_t node, SdoAddress address, std::uint32_t value,
                                   std::uint8_t size) noexcept;
can_frame make_sdo_download_response(std::uint8_t node, SdoAddress address) noexcept;
// An abort from the client (to_server: COB-ID 0x600 + node) or from the server (0x580 + node).
can_frame make_sdo_abort(std::uint8_t node, SdoAddress address, std::uint32_t abort_code, bool to_server) noexcept;
// A frame on 0x600 + node (what a server receives) and on 0x580 + node (what a client receives).
SdoMessage parse_sdo_request(const can_frame& frame) noexcept;
SdoMessage parse_sdo_response(const can_frame& frame) noexcept;
// The standard's words for an abort code ("object does not exist in the object dictionary"), or
// "unknown abort code" for one not in CiA 301's table.
std::string_view sdo_abort_text(std::uint32_t abort_code) noexcept;
// The abort codes used by name in Guideway's code and emulator.
inline constexpr std::uint32_t sdo_abort_timeout = 0x05040000;
inline constexpr std::uint32_t sdo_abort_command = 0x05040001;
inline constexpr std::uint32_t sdo_abort_write_read_only = 0x06010002;
inline constexpr std::uint32_t sdo_abort_no_object = 0x06020000;
inline constexpr std::uint32_t sdo_abort_length = 0x06070010;
inline constexpr std::uint32_t sdo_abort_no_sub = 0x06090011;
inline constexpr std::uint32_t sdo_abort_value = 0x06090030;
inline constexpr std::uint32_t sdo_abort_general = 0x08000000;
inline constexpr std::uint32_t sdo_abort_device_state = 0x08000022;

// "0x1018:4" (index in hex, sub-index in decimal).
std::string to_string(SdoAddress address);

}  // namespace guideway::drivers::can
