// Modbus TCP framing for a client that never waits (modbus_tcp.hpp): a register read's request and its answer's parse,
// pure.
#include "drivers/modbus/modbus_tcp.hpp"

namespace guideway::drivers::modbus {

namespace {

std::uint8_t function_code(RegisterFunction f) noexcept { return f == RegisterFunction::holding ? 0x03 : 0x04; }

std::uint16_t be16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>((static_cast<unsigned>(p[0]) << 8) | p[1]);
}

}  // namespace

std::array<std::uint8_t, tcp_request_bytes> tcp_read_request(std::uint16_t transaction, std::uint8_t unit,
                                                             RegisterFunction function, std::uint16_t address,
                                                             std::uint16_t count) noexcept {
  return {static_cast<std::uint8_t>(transaction >> 8),
          static_cast<std::uint8_t>(transaction & 0xFF),
          0,  // protocol identifier: Modbus
          0,
          0,  // length: unit identifier + the 5-byte PDU
          6,
          unit,
          function_code(function),
          static_cast<std::uint8_t>(address >> 8),
          static_cast<std::uint8_t>(address & 0xFF),
          static_cast<std::uint8_t>(count >> 8),
          static_cast<std::uint8_t>(count & 0xFF)};
}

TcpAnswer parse_tcp_answer(std::span<const std::uint8_t> bytes, std::uint16_t transaction, std::uint8_t unit,
                           RegisterFunction function, std::uint16_t count, std::span<std::uint16_t> out) {
  TcpAnswer a;
  if (bytes.size() < 7) return a;  // incomplete
  const std::uint8_t* p = bytes.data();
  a.transaction = be16(p);
  if (be16(p + 2) != 0) {
    a.kind = TcpAnswer::Kind::bad;
    a.why = "protocol identifier " + std::to_string(be16(p + 2)) + " (Modbus is 0)";
    return a;
  }
  const std::size_t length = be16(p + 4);  // unit identifier + PDU
  if (length < 3 || length > max_tcp_answer_bytes - 6) {
    a.kind = TcpAnswer::Kind::bad;
    a.why = "MBAP length " + std::to_string(length);
    return a;
  }
  if (bytes.size() < 6 + length) return a;  // incomplete
  a.length = 6 + length;
  if (a.transaction != transaction) {
    a.kind = TcpAnswer::Kind::other_transaction;
    return a;
  }
  const std::uint8_t fc = function_code(function);
  if (p[6] != unit) {
    a.kind = TcpAnswer::Kind::bad;
    a.why = "answer from unit " + std::to_string(p[6]) + ", asked unit " + std::to_string(unit);
    return a;
  }
  if (p[7] == (fc | 0x80)) {
    if (length != 3) {
      a.kind = TcpAnswer::Kind::bad;
      a.why = "exception response of " + std::to_string(length - 1) + " PDU bytes";
      return a;
    }
    a.kind = TcpAnswer::Kind::exception;
    a.exception_code = p[8];
    return a;
  }
  if (p[7] != fc) {
    a.kind = TcpAnswer::Kind::bad;
    a.why = "function code " + std::to_string(p[7]) + " in the answer to function " + std::to_string(fc);
    return a;
  }
  const std::size_t data_bytes = 2u * count;
  if (p[8] != data_bytes || length != 3 + data_bytes || out.size() < count) {
    a.kind = TcpAnswer::Kind::bad;
    a.why = "an answer of " + std::to_string(p[8]) + " data bytes to a read of " + std::to_string(count) + " registers";
    return a;
  }
  for (std::size_t i = 0; i < count; ++i) out[i] = be16(p + 9 + 2 * i);
  a.kind = TcpAnswer::Kind::registers;
  return a;
}

}  // namespace guideway::drivers::modbus
