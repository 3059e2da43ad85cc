// `guideway-emulate dbb`: the DBB bar and two axis encoders on a CAN bus (Unix gateway socket,
// SocketCAN interface, or an inherited fd), following a DBB circle.
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <tuple>

#include "simulators/emulators/can_serial_control.hpp"
#include "simulators/emulators/can_serial_machine_sources.hpp"
#include "simulators/emulators/dbb_emulator.hpp"
#include "simulators/emulators/emulator_command.hpp"

namespace guideway::simulators::emulators {

namespace {

struct DbbOptions {
  std::string bus = "unix:/tmp/guideway-can.sock";
  int fd = -1;
  std::string sync = "answer";
  double sync_rate_hz = 100.0;
  std::vector<int> nodes{1, 2, 3};
  double resolution_nm = 100.0;
  double radius_mm = 100.0;
  double height_mm = 0.0;
  double feed_mm_min = 1000.0;
  std::string direction = "ccw";
  std::string plane = "xy";
  double overshoot_deg = 45.0;
  std::string machine_file;
  double duration_s = 0.0;
  std::string program = "single";
  double pause_s = 1.0;
};

bool handle_fault(DbbEmulator& emu, const std::vector<std::string>& w, std::string& msg) {
  int n = 1;
  double s = 0;
  const std::string& c = w[0];
  if (c == "disconnect") {
    emu.inject_disconnect();
  } else if (c == "garbage" && word_to_int(w, 1, n)) {
    emu.inject_garbage(n);
  } else if (c == "truncated" && word_to_int(w, 1, n)) {
    emu.inject_truncated(n);
  } else if (c == "bad" && word_to_int(w, 1, n)) {
    emu.inject_bad_frames(n);
  } else if (c == "error-frames" && word_to_int(w, 1, n)) {
    emu.inject_error_frames(n);
  } else if (c == "bus-off") {
    int restart_ms = 200;
    if (w.size() > 1 && !word_to_int(w, 1, restart_ms)) return false;
    emu.inject_bus_off(restart_ms);
  } else if (c == "drop-pdo" && word_to_int(w, 1, n)) {
    int cycles = 1;
    if (w.size() > 2 && !word_to_int(w, 2, cycles)) return false;
    emu.inject_drop_pdo(static_cast<std::size_t>(n), cycles);
  } else if (c == "stall" && word_to_double(w, 1, s)) {
    emu.inject_stall(s);
  } else if (c == "burst" && word_to_int(w, 1, n)) {
    emu.inject_burst(n);
  } else if (c == "status") {
    msg = std::to_string(emu.cycles_sent()) + " cycles, " + std::to_string(emu.connections()) + " connections";
  } else {
    msg =
        "commands: disconnect | garbage N | truncated N | bad N | error-frames N | bus-off [RESTART_MS] | drop-pdo ENCODER [CYCLES]"
        " | stall SECONDS | burst N | status | quit";
    return false;
  }
  return true;
}

int run_dbb(const DbbOptions& o) {
  block_stop_signals();
  std::signal(SIGPIPE, SIG_IGN);  // a reader of our stdout that went away must not kill the emulator
  DbbEmulatorSettings settings;
  settings.produce_sync = o.sync == "produce";
  settings.sync_rate_hz = o.sync_rate_hz;
  const machine::Machine machine(o.machine_file.empty() ? machine::default_machine_config()
                                                        : machine::load_machine_config(o.machine_file));
  machine::DbbCircleSpec spec;
  spec.radius_m = o.radius_mm * 1e-3;
  spec.height_m = o.height_mm * 1e-3;
  spec.feed_m_per_s = o.feed_mm_min / 60e3;
  spec.direction = o.direction == "ccw" ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
  spec.plane = o.plane == "xz" ? machine::Plane::xz : o.plane == "yz" ? machine::Plane::yz : machine::Plane::xy;
  spec.overshoot_rad = o.overshoot_deg * 3.14159265358979323846 / 180.0;
  spec.sample_rate_hz = 1000.0;
  // "lai": Lai's three patterns with one 100 mm bar (h = 31.225 mm at r = 95 mm cw and ccw, then
  // h = 0 at r = 100 mm ccw), a pause after each, repeated; "single": the one circle of the options.
  std::vector<machine::DbbCircleSpec> specs;
  if (o.program == "lai") {
    for (auto [r_mm, h_mm, dir] : {std::tuple{95.0, 31.225, formats::DbbDirection::cw}, std::tuple{95.0, 31.225, formats::DbbDirection::ccw},
                                   std::tuple{100.0, 0.0, formats::DbbDirection::ccw}}) {
      machine::DbbCircleSpec p = spec;
      p.radius_m = r_mm * 1e-3;
      p.height_m = h_mm * 1e-3;
      p.direction = dir;
      specs.push_back(p);
    }
  } else {
    specs.push_back(spec);
  }
  auto program = make_dbb_program(machine, specs, o.pause_s);
  const double nominal_length_m = program->runs.front().nominal_length_m;
  const char* names[] = {"bar_length", o.plane == "yz" ? "y" : "x", o.plane == "xy" ? "y" : "z"};
  for (std::size_t i = 0; i < 3; ++i) {
    drivers::dbb::EncoderScale e;
    e.channel = names[i];
    e.node_id = static_cast<std::uint8_t>(o.nodes[i]);
    e.resolution_m = o.resolution_nm * 1e-9;
    if (i == 0) e.offset_m = std::round(nominal_length_m * 1e6) * 1e-6;  // the bar's nominal, in um
    settings.encoders.push_back(e);
  }
  DbbSource circle = dbb_program_source(machine, specs, o.pause_s);
  DbbEmulator emu(settings, circle);
  std::string error;
  drivers::can::CanSocket listener;
  if (o.fd >= 0) {
    emu.attach(drivers::can::CanSocket(o.fd));
    std::printf("bus: fd %d\nendpoint: fd:%d\n", o.fd, o.fd);
  } else {
    drivers::can::CanEndpoint ep;
    if (!drivers::can::parse_can_endpoint(o.bus, ep, error)) throw std::runtime_error(error);
    if (ep.kind == drivers::can::CanEndpoint::Kind::unix_gateway) {
      listener = drivers::can::listen_can_gateway(ep.name, error);
      if (!listener.valid()) throw std::runtime_error(error);
    } else {
      drivers::can::CanSocket s = drivers::can::open_socketcan(ep.name, error);
      if (!s.valid()) throw std::runtime_error(error);
      emu.attach(std::move(s));
    }
    // "endpoint:" is read by the daemon's emulator launcher; the address is what the driver's `bus` takes.
    std::printf("bus: %s\nendpoint: %s\n", drivers::can::to_string(ep).c_str(), drivers::can::to_string(ep).c_str());
  }
  std::fflush(stdout);
  emu.start(std::move(listener));
  const int rc = run_control_loop([&](const auto& w, std::string& m) { return handle_fault(emu, w, m); }, o.duration_s);
  emu.stop();
  return rc;
}

void add_dbb(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<DbbOptions>();
  auto* cmd = app.add_subcommand("dbb", "double ball bar + X/Y encoders on CAN (CiA 406 style TPDOs on SYNC)");
  cmd->add_option("--bus", o->bus, "unix:PATH (SEQPACKET gateway to listen on) or can:IFNAME (SocketCAN)")
      ->capture_default_str();
  cmd->add_option("--fd", o->fd, "serve an inherited fd carrying can_frame records instead of --bus");
  cmd->add_option("--sync", o->sync, "answer the driver's SYNC, or produce SYNC like a controller")
      ->check(CLI::IsMember({"answer", "produce"}))
      ->capture_default_str();
  cmd->add_option("--sync-rate-hz", o->sync_rate_hz, "SYNC rate when producing")->capture_default_str();
  cmd->add_option("--nodes", o->nodes, "node IDs of bar, first axis, second axis")->expected(3)->capture_default_str();
  cmd->add_option("--resolution-nm", o->resolution_nm, "encoder resolution")->capture_default_str();
  cmd->add_option("--machine", o->machine_file, "virtual machine tool file (default: config/machine-example.toml, compiled in)");
  cmd->add_option("--radius-mm", o->radius_mm, "circle radius")->capture_default_str();
  cmd->add_option("--height-mm", o->height_mm, "tool ball above the centre ball (Lai's h)")->capture_default_str();
  cmd->add_option("--feed-mm-min", o->feed_mm_min, "feed rate")->capture_default_str();
  cmd->add_option("--direction", o->direction, "ccw or cw")->check(CLI::IsMember({"ccw", "cw"}))->capture_default_str();
  cmd->add_option("--plane", o->plane, "circle plane")->check(CLI::IsMember({"xy", "xz", "yz"}))->capture_default_str();
  cmd->add_option("--overshoot-deg", o->overshoot_deg, "feed-in/feed-out arcs")->capture_default_str();
  cmd->add_option("--program", o->program, "single: the circle of the options; lai: Lai's three patterns in turn")
      ->check(CLI::IsMember({"single", "lai"}))
      ->capture_default_str();
  cmd->add_option("--pause-s", o->pause_s, "standing still after each circle")->capture_default_str();
  cmd->add_option("--duration-s", o->duration_s, "stop after this long (0: until quit/SIGTERM)")->capture_default_str();
  cmd->callback([o, &exit_code] { exit_code = run_dbb(*o); });
}

const EmulatorCommand registration(&add_dbb);

}  // namespace

}  // namespace guideway::simulators::emulators
