// `guideway-emulate dbb`: the DBB bar and two axis encoders on a CAN bus (Unix gateway socket,
// SocketCAN interface, or an inherited fd), following a DBB circle.
#include <cmath>
#include <cstdio>
#include <iostream>

#include "simulators/emulators/can_serial_control.hpp"
#include "simulators/emulators/dbb_emulator.hpp"
#include "simulators/emulators/emulator_command.hpp"

namespace guideway::emulators {

namespace {

struct DbbOptions {
  std::string bus = "unix:/tmp/guideway-can.sock";
  int fd = -1;
  std::string sync = "answer";
  double sync_rate_hz = 100.0;
  std::vector<int> nodes{1, 2, 3};
  double resolution_nm = 100.0;
  double bar_length_mm = 100.0;
  double radius_mm = 100.0;
  double feed_mm_min = 1000.0;
  std::string direction = "ccw";
  double bar_error_um = 0.0;
  double duration_s = 0.0;
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
    emu.inject_error_frames(1, true);
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
    msg = "commands: disconnect | garbage N | truncated N | bad N | error-frames N | bus-off | drop-pdo ENCODER [CYCLES]"
          " | stall SECONDS | burst N | status | quit";
    return false;
  }
  return true;
}

int run_dbb(const DbbOptions& o) {
  block_stop_signals();
  DbbEmulatorSettings settings;
  settings.produce_sync = o.sync == "produce";
  settings.sync_rate_hz = o.sync_rate_hz;
  const char* names[] = {"bar_length", "x", "y"};
  for (std::size_t i = 0; i < 3; ++i) {
    dbb::EncoderScale e;
    e.channel = names[i];
    e.node_id = static_cast<std::uint8_t>(o.nodes[i]);
    e.resolution_m = o.resolution_nm * 1e-9;
    if (i == 0) e.offset_m = o.bar_length_mm * 1e-3;
    settings.encoders.push_back(e);
  }
  const double radius_m = o.radius_mm * 1e-3;
  DbbSource circle = ideal_circle_source(radius_m, o.feed_mm_min / 60e3, o.direction == "ccw" ? 1 : -1,
                                         o.bar_error_um * 1e-6);
  // The bar reads its length relative to the nominal: offset is the nominal length, so the
  // source's bar value (radius) is reported as-is when radius == nominal length.
  DbbEmulator emu(settings, circle);
  std::string error;
  can::CanSocket listener;
  if (o.fd >= 0) {
    emu.attach(can::CanSocket(o.fd));
    std::printf("bus: fd %d\n", o.fd);
  } else {
    can::CanEndpoint ep;
    if (!can::parse_can_endpoint(o.bus, ep, error)) throw std::runtime_error(error);
    if (ep.kind == can::CanEndpoint::Kind::unix_gateway) {
      listener = can::listen_can_gateway(ep.name, error);
      if (!listener.valid()) throw std::runtime_error(error);
    } else {
      can::CanSocket s = can::open_socketcan(ep.name, error);
      if (!s.valid()) throw std::runtime_error(error);
      emu.attach(std::move(s));
    }
    std::printf("bus: %s\n", can::to_string(ep).c_str());
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
  cmd->add_option("--bar-length-mm", o->bar_length_mm, "nominal bar length (bar encoder zero)")->capture_default_str();
  cmd->add_option("--radius-mm", o->radius_mm, "circle radius")->capture_default_str();
  cmd->add_option("--feed-mm-min", o->feed_mm_min, "feed rate")->capture_default_str();
  cmd->add_option("--direction", o->direction, "ccw or cw")->check(CLI::IsMember({"ccw", "cw"}))->capture_default_str();
  cmd->add_option("--bar-error-um", o->bar_error_um, "constant bar length error")->capture_default_str();
  cmd->add_option("--duration-s", o->duration_s, "stop after this long (0: until quit/SIGTERM)")->capture_default_str();
  cmd->callback([o, &exit_code] { exit_code = run_dbb(*o); });
}

const EmulatorCommand registration(&add_dbb);

}  // namespace

}  // namespace guideway::emulators
