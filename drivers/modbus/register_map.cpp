// A gauge amplifier's register map from configuration (register_map.hpp), and the pure decoder from registers to a
// reading.
#include "drivers/modbus/register_map.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "core/sample.hpp"

namespace guideway::drivers::modbus {

std::string_view to_string(ValueType t) noexcept {
  switch (t) {
    case ValueType::int16:
      return "int16";
    case ValueType::uint16:
      return "uint16";
    case ValueType::int32:
      return "int32";
    case ValueType::uint32:
      return "uint32";
    case ValueType::float32:
      return "float32";
  }
  return "?";
}

std::optional<ValueType> value_type_from_string(std::string_view s) noexcept {
  for (ValueType t : {ValueType::int16, ValueType::uint16, ValueType::int32, ValueType::uint32, ValueType::float32}) {
    if (to_string(t) == s) return t;
  }
  return std::nullopt;
}

std::uint16_t RegisterMap::block_start() const noexcept {
  return status_address ? std::min(value_address, *status_address) : value_address;
}

std::uint16_t RegisterMap::block_count() const noexcept {
  std::uint32_t end = std::uint32_t{value_address} + register_count(value_type);
  if (status_address) end = std::max(end, std::uint32_t{*status_address} + 1);
  return static_cast<std::uint16_t>(std::min<std::uint32_t>(end - block_start(), 0xffff));
}

std::string RegisterMap::validate() const {
  const std::uint32_t value_end = std::uint32_t{value_address} + register_count(value_type);
  if (value_end > 0x10000) return "value register beyond address 65535";
  if (status_address && *status_address >= value_address && *status_address < value_end) {
    return "status register overlaps the value register(s)";
  }
  if (block_count() > 125) return "value and status registers more than 125 registers apart (one read request)";
  if (!std::isfinite(scale_um) || scale_um == 0.0) return "scale_um must be finite and non-zero";
  if (!std::isfinite(offset_um)) return "offset_um must be finite";
  return {};
}

RegisterMap parse_register_map(const TableReader& t) {
  RegisterMap m;
  m.function = t.get_choice("function", "input", {"input", "holding"}) == "holding" ? RegisterFunction::holding
                                                                                    : RegisterFunction::input;
  m.value_address = static_cast<std::uint16_t>(t.get_int("value_address", 0, 0, 65535));
  m.value_type =
      *value_type_from_string(t.get_choice("value_type", "int32", {"int16", "uint16", "int32", "uint32", "float32"}));
  m.word_order = t.get_choice("word_order", "big", {"big", "little"}) == "little" ? WordOrder::little : WordOrder::big;
  m.scale_um = t.get_double("scale_um", 0.01);
  m.offset_um = t.get_double("offset_um", 0.0);
  const std::int64_t status = t.get_int("status_address", 2, -1, 65535);
  m.status_address = status < 0 ? std::nullopt : std::optional<std::uint16_t>(static_cast<std::uint16_t>(status));
  m.out_of_range_mask = static_cast<std::uint16_t>(t.get_int("out_of_range_mask", 0x0001, 0, 0xffff));
  m.probe_missing_mask = static_cast<std::uint16_t>(t.get_int("probe_missing_mask", 0x0002, 0, 0xffff));
  if (const std::string why = m.validate(); !why.empty()) t.fail("value_address", why);
  return m;
}

namespace {

std::uint32_t join_words(const RegisterMap& map, std::uint16_t first, std::uint16_t second) noexcept {
  return map.word_order == WordOrder::big ? (std::uint32_t{first} << 16) | second
                                          : (std::uint32_t{second} << 16) | first;
}

}  // namespace

Reading decode_registers(const RegisterMap& map, std::span<const std::uint16_t> block) noexcept {
  Reading r;
  if (!map.validate().empty() || block.size() < map.block_count()) return r;
  const std::size_t v = map.value_address - map.block_start();
  switch (map.value_type) {
    case ValueType::int16:
      r.raw = static_cast<std::int16_t>(block[v]);
      break;
    case ValueType::uint16:
      r.raw = block[v];
      break;
    case ValueType::int32:
      r.raw = static_cast<std::int32_t>(join_words(map, block[v], block[v + 1]));
      break;
    case ValueType::uint32:
      r.raw = join_words(map, block[v], block[v + 1]);
      break;
    case ValueType::float32:
      r.raw = std::bit_cast<float>(join_words(map, block[v], block[v + 1]));
      break;
  }
  r.valid = true;
  if (map.status_address) {
    const std::uint16_t status = block[*map.status_address - map.block_start()];
    if (status & map.out_of_range_mask) r.flags |= sample_out_of_range;
    if (status & map.probe_missing_mask) r.flags |= sample_no_signal;
  }
  const double um = r.raw * map.scale_um + map.offset_um;
  if (!std::isfinite(um)) r.flags |= sample_out_of_range;
  r.value_m = r.flags != 0 ? std::numeric_limits<double>::quiet_NaN() : um * 1e-6;
  return r;
}

std::vector<std::uint16_t> encode_registers(const RegisterMap& map, double value_m, std::uint16_t status) {
  std::vector<std::uint16_t> block(map.block_count(), 0);
  const std::size_t v = map.value_address - map.block_start();
  const double counts = (value_m * 1e6 - map.offset_um) / map.scale_um;
  auto saturate = [&](double lo, double hi) {
    if (std::isnan(counts)) return 0.0;
    return std::clamp(std::round(counts), lo, hi);
  };
  auto put32 = [&](std::uint32_t u) {
    const auto hi = static_cast<std::uint16_t>(u >> 16);
    const auto lo = static_cast<std::uint16_t>(u & 0xffff);
    block[v] = map.word_order == WordOrder::big ? hi : lo;
    block[v + 1] = map.word_order == WordOrder::big ? lo : hi;
  };
  switch (map.value_type) {
    case ValueType::int16:
      block[v] = static_cast<std::uint16_t>(static_cast<std::int16_t>(saturate(-32768.0, 32767.0)));
      break;
    case ValueType::uint16:
      block[v] = static_cast<std::uint16_t>(saturate(0.0, 65535.0));
      break;
    case ValueType::int32:
      put32(static_cast<std::uint32_t>(static_cast<std::int32_t>(saturate(-2147483648.0, 2147483647.0))));
      break;
    case ValueType::uint32:
      put32(static_cast<std::uint32_t>(saturate(0.0, 4294967295.0)));
      break;
    case ValueType::float32:
      put32(std::bit_cast<std::uint32_t>(static_cast<float>(counts)));
      break;
  }
  if (map.status_address) block[*map.status_address - map.block_start()] = status;
  return block;
}

}  // namespace guideway::drivers::modbus
