// `guideway ports`: the serial ports of this machine with their USB VID:PID, serial number and
// product, to find the autocollimator's `port` for the configuration (prefer /dev/serial/by-id).
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli/commands.hpp"
#include "drivers/serial/serial_port.hpp"
#include "results/message_class.hpp"

namespace guideway::cli {

namespace {

std::string hex4(int v) {
  std::ostringstream s;
  s << std::hex << std::setw(4) << std::setfill('0') << v;
  return s.str();
}

// /dev/serial/by-id/<link> -> target, so the stable name can be shown next to /dev/ttyUSBn.
std::map<std::string, std::string> stable_names() {
  std::map<std::string, std::string> out;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/dev/serial/by-id", ec)) {
    const auto target = std::filesystem::canonical(e.path(), ec);
    if (!ec) out[target.string()] = e.path().string();
  }
  return out;
}

struct PortsArgs {
  bool json = false;
  bool usb_only = false;
  void add(CLI::App& cmd) {
    cmd.add_flag("--json", json, "one JSON object per port, one per line");
    cmd.add_flag("--usb", usb_only, "only USB ports");
  }
};

// A port as one JSON line: its name and transport, the USB facts it has, its stable name.
nlohmann::json port_json(const drivers::serial::SerialPortInfo& p, const std::string& by_id) {
  nlohmann::json j = results::with_class(results::MessageClass::port, {{"name", p.name}, {"transport", p.transport}});
  if (!p.description.empty()) j["description"] = p.description;
  if (!by_id.empty()) j["by_id"] = by_id;
  if (p.usb_vid >= 0) j["usb_vid"] = hex4(p.usb_vid);
  if (p.usb_pid >= 0) j["usb_pid"] = hex4(p.usb_pid);
  if (!p.usb_serial.empty()) j["usb_serial"] = p.usb_serial;
  if (!p.usb_manufacturer.empty()) j["usb_manufacturer"] = p.usb_manufacturer;
  if (!p.usb_product.empty()) j["usb_product"] = p.usb_product;
  return j;
}

void run_ports(const PortsArgs& a, CliContext& ctx) {
  std::vector<drivers::serial::SerialPortInfo> list;
  std::string error;
  if (!drivers::serial::list_serial_ports(list, error)) throw std::runtime_error(error);
  const auto by_id = stable_names();
  std::size_t shown = 0;
  for (const auto& p : list) {
    if (a.usb_only && p.transport != "usb") continue;
    ++shown;
    const auto stable = by_id.find(p.name);
    if (a.json) {
      std::cout << port_json(p, stable != by_id.end() ? stable->second : std::string()).dump() << "\n";
      continue;
    }
    if (shown == 1) {
      std::cout << std::left << std::setw(16) << "PORT" << std::setw(11) << "TRANSPORT" << std::setw(11) << "VID:PID"
                << std::setw(18) << "SERIAL"
                << "DESCRIPTION\n";
    }
    const std::string vidpid = p.usb_vid >= 0 ? hex4(p.usb_vid) + ":" + hex4(p.usb_pid) : "-";
    std::cout << std::left << std::setw(16) << p.name << std::setw(11) << p.transport << std::setw(11) << vidpid
              << std::setw(18) << (p.usb_serial.empty() ? "-" : p.usb_serial) << p.description << "\n";
    if (stable != by_id.end()) std::cout << "  stable name: " << stable->second << "\n";
  }
  if (shown == 0 && !a.json) std::cout << "no serial ports found\n";
  ctx.exit_code = 0;
}

void add_ports_commands(CLI::App& app, CliContext& ctx) {
  add_commands(app, ctx,
               {command("ports", "List serial ports (USB VID:PID, serial number) for the configuration", &run_ports)});
}

const CommandGroup group(&add_ports_commands);

}  // namespace

}  // namespace guideway::cli
