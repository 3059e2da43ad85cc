#pragma once
// Register map of a gauge amplifier read over Modbus, and the pure decoder registers -> reading.
// The map comes from configuration, so a real amplifier is mapped without code. Everything here is
// a pure function of its arguments (thread safe, no I/O), so it can be fuzzed.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/toml_access.hpp"

namespace guideway::drivers::modbus {

enum class RegisterFunction { holding, input };  // read with FC 3 or FC 4
enum class ValueType { int16, uint16, int32, uint32, float32 };
enum class WordOrder { big, little };  // big: high word first ("ABCD"); little: low word first ("CDAB")

std::string_view to_string(ValueType t) noexcept;
std::optional<ValueType> value_type_from_string(std::string_view s) noexcept;
[[nodiscard]] constexpr std::uint16_t register_count(ValueType t) noexcept {
  return (t == ValueType::int16 || t == ValueType::uint16) ? 1 : 2;
}

struct RegisterMap {
  RegisterFunction function = RegisterFunction::input;
  std::uint16_t value_address = 0;
  ValueType value_type = ValueType::int32;
  WordOrder word_order = WordOrder::big;
  double scale_um = 0.01;                           // micrometres per count (float32: per unit of the register value)
  double offset_um = 0.0;                           // added after scaling
  std::optional<std::uint16_t> status_address = 2;  // a 16-bit status word, if the amplifier has one
  std::uint16_t out_of_range_mask = 0x0001;         // status bits meaning "over/under range"
  std::uint16_t probe_missing_mask = 0x0002;        // status bits meaning "probe unplugged / no signal"

  // The contiguous block read in one request: [block_start, block_start + block_count).
  [[nodiscard]] std::uint16_t block_start() const noexcept;
  [[nodiscard]] std::uint16_t block_count() const noexcept;
  // Empty when valid, else why not (overlapping value/status, block longer than 125 registers, ...).
  [[nodiscard]] std::string validate() const;
};

// Reads the map from a [device.registers] table (every key optional, defaults as above).
// Throws ConfigError with file:line:key on a bad value.
RegisterMap parse_register_map(const TableReader& table);

struct Reading {
  bool valid = false;       // false: block too short or map invalid; nothing else is meaningful
  double value_m = 0.0;     // displacement in metres; NaN when flagged
  std::uint32_t flags = 0;  // guideway::SampleFlag bits (out_of_range, no_signal)
  double raw = 0.0;         // the register value before scaling (counts or float32)
};

// Decodes one block read with map.block_start()/block_count(). Never throws.
// A flagged status or a non-finite float32 yields value_m = NaN and a flag: reported, not a number.
Reading decode_registers(const RegisterMap& map, std::span<const std::uint16_t> block) noexcept;

// The inverse, for emulators and tests: the registers an amplifier shows for displacement value_m
// (rounded to the register's resolution, saturated to its type) and the given status word.
std::vector<std::uint16_t> encode_registers(const RegisterMap& map, double value_m, std::uint16_t status = 0);

}  // namespace guideway::drivers::modbus
