#pragma once
// Modbus TCP framing (the MBAP header of the Modbus Messaging on TCP/IP Implementation Guide) for a
// client that never waits: the request of a register read and the parse of its answer, pure (no
// I/O, no clock), so the loop-driven micrometer and the fuzz tests share them. libmodbus has no
// non-blocking client; its server (the emulator) and pymodbus check this framing in the tests.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "drivers/modbus/register_map.hpp"

namespace guideway::drivers::modbus {

inline constexpr std::size_t tcp_request_bytes = 12;
inline constexpr std::size_t max_tcp_answer_bytes = 260;  // 7-byte MBAP header + at most 253 PDU bytes

// Read `count` registers (1..125) at `address` with FC 3 (holding) or FC 4 (input) from `unit`.
std::array<std::uint8_t, tcp_request_bytes> tcp_read_request(std::uint16_t transaction, std::uint8_t unit,
                                                             RegisterFunction function, std::uint16_t address,
                                                             std::uint16_t count) noexcept;

struct TcpAnswer {
  enum class Kind {
    incomplete,         // not a whole frame yet: read on
    registers,          // the answer: `count` registers in `out`
    exception,          // the answer: an exception response with `exception_code`
    other_transaction,  // a whole, well-formed frame of another transaction (a late answer): skip it
    bad,                // not a Modbus TCP answer to this request (`why`): nothing after it can be trusted
  };
  Kind kind = Kind::incomplete;
  std::size_t length = 0;  // bytes of the frame at the front (registers, exception, other_transaction)
  std::uint16_t transaction = 0;
  int exception_code = 0;
  std::string why;
};

// Looks at the front of `bytes` for the answer to the request (transaction, unit, function, count).
// Never throws, whatever the bytes.
TcpAnswer parse_tcp_answer(std::span<const std::uint8_t> bytes, std::uint16_t transaction, std::uint8_t unit,
                           RegisterFunction function, std::uint16_t count, std::span<std::uint16_t> out);

}  // namespace guideway::drivers::modbus
