// The instrument lines of the commands' readable output (instrument_print.hpp).
#include "cli/instrument_print.hpp"

#include <string>

#include "core/number_format.hpp"
#include "core/printable.hpp"

namespace guideway::cli {

namespace {

std::string field(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_string() ? printable(it->get<std::string>()) : std::string();
}

// "serial 1001, certificate C-17, calibrated 2023-01-10, due 2024-01-10, bar 100.0000 mm (u 0.5 um)"
std::string instrument_text(const nlohmann::json& in) {
  std::string out;
  const auto add = [&out](const std::string& label, const std::string& value) {
    if (!value.empty()) out += (out.empty() ? "" : ", ") + label + value;
  };
  add("serial ", field(in, "serial"));
  add("certificate ", field(in, "calibration_certificate"));
  add("calibrated ", field(in, "calibrated_on"));
  add("due ", field(in, "calibration_due"));
  if (const auto l = in.find("calibrated_length_mm"); l != in.end() && l->is_number()) {
    std::string bar = printf_number("%.4f mm", l->get<double>());
    if (const auto u = in.find("calibrated_length_u_um"); u != in.end() && u->is_number())
      bar += " (u " + significant_digits(u->get<double>(), 3) + " um)";
    add("bar ", bar);
  }
  return out;
}

}  // namespace

void print_instrument(const nlohmann::json& message, std::ostream& out) {
  const auto in = message.find("instrument");
  if (in == message.end() || !in->is_object()) return;
  out << "instrument: " << instrument_text(*in) << "\n";
  if (const std::string w = field(*in, "warning"); !w.empty()) out << "WARNING: " << w << "\n";
}

void print_device_instrument(const nlohmann::json& device, int indent, std::ostream& out) {
  const std::string pad(static_cast<std::size_t>(indent), ' ');
  if (const auto in = device.find("instrument"); in != device.end() && in->is_object())
    out << pad << "instrument: " << instrument_text(*in) << "\n";
  if (const auto w = device.find("warnings"); w != device.end() && w->is_array())
    for (const auto& line : *w)
      if (line.is_string()) out << pad << "WARNING: " << printable(line.get<std::string>()) << "\n";
}

void print_warnings(const nlohmann::json& reply, std::ostream& out) {
  if (const auto w = reply.find("warnings"); w != reply.end() && w->is_array())
    for (const auto& line : *w)
      if (line.is_string()) out << "WARNING: " << printable(line.get<std::string>()) << "\n";
}

}  // namespace guideway::cli
