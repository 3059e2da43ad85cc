// `guideway-emulate dbb`: the DBB bar and the axis encoders (the plane's two, and the normal axis's
// when a fourth node is given; following LinuxCNC, its servo period's number on a fifth) on a CAN bus (Unix gateway
// socket, SocketCAN interface, or an inherited fd), following a DBB circle.
#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <numbers>
#include <tuple>

#include "simulators/emulators/can_serial_control.hpp"
#include "simulators/emulators/can_serial_machine_sources.hpp"
#include "simulators/emulators/dbb_emulator.hpp"
#include "simulators/emulators/emulator_command.hpp"
#include "simulators/emulators/linuxcnc_follower.hpp"

namespace guideway::simulators::emulators {

namespace {

constexpr double pi = std::numbers::pi;
// The controller_period node's "metres" per count: a thousandth of a servo period (docs/linuxcnc.md).
constexpr double controller_period_resolution = 1e-3;

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
  int heartbeat_ms = 0;
  int transmission_type = 1;
  bool auto_start = false;
  std::vector<std::uint32_t> serial_numbers;
  std::string follow;                        // the bridge's socket: move as LinuxCNC commands
  double follow_delay_ms = 300.0;
  std::vector<double> center_mm{0.0, 0.0, 0.0};  // the bar's fixed ball (the circle's commanded centre)
};

std::string node_states_text(const DbbEmulator& emu) {
  std::string out;
  for (const auto st : emu.node_states()) {
    if (!out.empty()) out += ", ";
    out += st == drivers::can::NmtState::boot_up ? std::string("off") : std::string(drivers::can::to_string(st));
  }
  return out;
}

// The CANopen node faults; `n` is the encoder index (0 = bar).
bool handle_node_fault(DbbEmulator& emu, const std::vector<std::string>& w, int n) {
  const std::string& c = w[0];
  const auto encoder = static_cast<std::size_t>(n);
  double s = 0;
  std::uint32_t code = 0;
  if (c == "reboot") {
    int down_ms = 100;
    if (w.size() > 2 && !word_to_int(w, 2, down_ms)) return false;
    emu.inject_reboot(encoder, down_ms * 1e-3);
  } else if (c == "heartbeat-loss" && word_to_double(w, 2, s)) {
    emu.inject_mute(encoder, s);
  } else if (c == "sdo-abort" && w.size() > 2) {
    if (w[2] == "off")
      code = 0;
    else if (!word_to_u32(w, 2, code))
      return false;
    emu.inject_sdo_abort(encoder, code);
  } else if (c == "identity" && word_to_u32(w, 2, code)) {
    EncoderNodeIdentity id;
    id.serial_number = code;
    if (w.size() > 3 && !word_to_u32(w, 3, id.vendor_id)) return false;
    if (w.size() > 4 && !word_to_u32(w, 4, id.product_code)) return false;
    if (w.size() > 5 && !word_to_u32(w, 5, id.revision_number)) return false;
    emu.inject_identity(encoder, id);
  } else if (c == "emcy" && word_to_u32(w, 2, code) && code <= 0xFFFF) {
    std::uint32_t reg = code == 0 ? 0 : 0x01;
    if (w.size() > 3 && (!word_to_u32(w, 3, reg) || reg > 0xFF)) return false;
    emu.inject_emcy(encoder, static_cast<std::uint16_t>(code), static_cast<std::uint8_t>(reg));
  } else {
    return false;
  }
  return true;
}

bool handle_fault(DbbEmulator& emu, const std::vector<std::string>& w, std::string& msg) {
  int n = 1;
  double s = 0;
  const std::string& c = w[0];
  if ((c == "reboot" || c == "heartbeat-loss" || c == "sdo-abort" || c == "identity" || c == "emcy") &&
      word_to_int(w, 1, n) && n >= 0 && n < static_cast<int>(emu.node_states().size())) {
    if (handle_node_fault(emu, w, n)) return true;
    msg =
        "usage: reboot ENCODER [DOWN_MS] | heartbeat-loss ENCODER SECONDS | sdo-abort ENCODER CODE|off"
        " | identity ENCODER SERIAL [VENDOR PRODUCT REVISION] | emcy ENCODER CODE [REGISTER]";
    return false;
  }
  if (c == "nodes") {
    msg = node_states_text(emu);
    return true;
  }
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
    msg = std::to_string(emu.cycles_sent()) + " cycles, " + std::to_string(emu.connections()) + " connections, nodes " +
          node_states_text(emu);
  } else {
    msg =
        "commands: disconnect | garbage N | truncated N | bad N | error-frames N | bus-off [RESTART_MS]"
        " | drop-pdo ENCODER [CYCLES] | stall SECONDS | burst N | reboot ENCODER [DOWN_MS] | heartbeat-loss ENCODER "
        "SECONDS"
        " | sdo-abort ENCODER CODE|off | identity ENCODER SERIAL [VENDOR PRODUCT REVISION] | emcy ENCODER CODE "
        "[REGISTER]"
        " | nodes | status | circle FEED_MM_MIN [RADIUS_MM] | quit";
    return false;
  }
  return true;
}

// The circles of a program. "single": the one circle of the options; "standard": ccw then cw at h = 0 in
// the plane (the standard ballbar test); "three-plane": xy 360 deg, then xz and yz 220 deg above the
// centre (the table is below), ccw then cw each, with feed-in/feed-out arcs of at most 10 deg there (the
// table and the spindle head leave no more); "lai": Lai's three patterns with one 100 mm bar (h = 31.225
// mm at r = 95 mm cw and ccw, then h = 0 at r = 100 mm ccw). A pause after each circle, repeated.
std::vector<machine::DbbCircleSpec> program_specs(const std::string& program, const machine::DbbCircleSpec& spec) {
  using formats::DbbDirection;
  std::vector<machine::DbbCircleSpec> specs;
  if (program == "lai") {
    for (auto [r_mm, h_mm, dir] :
         {std::tuple{95.0, 31.225, DbbDirection::cw}, std::tuple{95.0, 31.225, DbbDirection::ccw},
          std::tuple{100.0, 0.0, DbbDirection::ccw}}) {
      machine::DbbCircleSpec p = spec;
      p.radius_m = r_mm * 1e-3;
      p.height_m = h_mm * 1e-3;
      p.direction = dir;
      specs.push_back(p);
    }
  } else if (program == "standard" || program == "three-plane") {
    const bool three = program == "three-plane";
    for (const machine::Plane plane : {spec.plane, machine::Plane::xz, machine::Plane::yz}) {
      for (const DbbDirection dir : {DbbDirection::ccw, DbbDirection::cw}) {
        machine::DbbCircleSpec p = spec;
        p.height_m = 0.0;
        p.direction = dir;
        p.plane = three ? plane : spec.plane;
        if (p.plane != machine::Plane::xy && three) {
          p.data_arc_rad = 220.0 * pi / 180.0;
          p.overshoot_rad = std::min(spec.overshoot_rad, 10.0 * pi / 180.0);
          p.start_angle_rad =
              (dir == DbbDirection::ccw ? -20.0 : 200.0) * pi / 180.0;  // the arc about +90 deg: z above
        }
        specs.push_back(p);
      }
      if (!three) break;
    }
  } else {
    specs.push_back(spec);
  }
  return specs;
}

// `circle FEED_MM_MIN [RADIUS_MM]`: the program's circles from the next one on at this feed (and radius), as an
// operator runs the CNC program at the session's feed; guidewayd sends it when a session starts
// (daemon/emulator_launcher.hpp). Following LinuxCNC, the controller's program sets the circle.
bool retarget_circles(DbbProgramPlayer* player, const std::vector<std::string>& w, std::string& msg) {
  double feed_mm_min = 0, radius_mm = 0;
  if (!player) {
    msg = "following LinuxCNC: its program sets the circle";
    return false;
  }
  if (w.size() < 2 || w.size() > 3 || !word_to_double(w, 1, feed_mm_min) || !(feed_mm_min > 0) ||
      !(feed_mm_min < 1e6) || (w.size() == 3 && (!word_to_double(w, 2, radius_mm) || !(radius_mm > 0) ||
                                                  !(radius_mm < 1e4)))) {
    msg = "usage: circle FEED_MM_MIN [RADIUS_MM] (positive numbers)";
    return false;
  }
  player->retarget(feed_mm_min / 60e3, radius_mm * 1e-3);
  msg = "from the next circle on: " + w[1] + " mm/min" + (w.size() == 3 ? ", r = " + w[2] + " mm" : "");
  return true;
}

int run_dbb(const DbbOptions& o) {
  block_stop_signals();
  std::signal(SIGPIPE, SIG_IGN);  // a reader of our stdout that went away must not kill the emulator
  DbbEmulatorSettings settings;
  settings.produce_sync = o.sync == "produce";
  settings.sync_rate_hz = o.sync_rate_hz;
  settings.heartbeat_ms = static_cast<std::uint16_t>(o.heartbeat_ms);
  settings.transmission_type = static_cast<std::uint8_t>(o.transmission_type);
  settings.nodes_start_operational = o.auto_start;
  for (const std::uint32_t serial : o.serial_numbers) {
    EncoderNodeIdentity id;
    id.serial_number = serial;
    settings.identities.push_back(id);
  }
  const machine::Machine machine(o.machine_file.empty() ? machine::default_machine_config()
                                                        : machine::load_machine_config(o.machine_file));
  machine::DbbCircleSpec spec;
  spec.radius_m = o.radius_mm * 1e-3;
  spec.height_m = o.height_mm * 1e-3;
  spec.feed_m_per_s = o.feed_mm_min / 60e3;
  spec.direction = o.direction == "ccw" ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
  spec.plane = o.plane == "xz" ? machine::Plane::xz : o.plane == "yz" ? machine::Plane::yz : machine::Plane::xy;
  spec.overshoot_rad = o.overshoot_deg * pi / 180.0;
  spec.sample_rate_hz = 1000.0;
  const std::vector<machine::DbbCircleSpec> specs = program_specs(o.program, spec);
  std::vector<int> nodes = o.nodes;
  if (o.program == "three-plane" && nodes.size() < 4) {
    // The three planes need every axis on the bus: the normal axis's encoder on the next node.
    nodes.push_back(*std::max_element(nodes.begin(), nodes.end()) + 1);
  }
  // Following LinuxCNC the machine moves as the controller commands; else it runs the program's circles.
  std::unique_ptr<LinuxcncFollower> follower;
  std::shared_ptr<DbbProgramPlayer> player;  // the program's circles (not when following LinuxCNC)
  DbbSource circle;
  double nominal_length_m = 0;
  if (!o.follow.empty()) {
    FollowSettings fs;
    fs.socket_path = o.follow;
    fs.plane = spec.plane;
    fs.radius_m = spec.radius_m;
    fs.height_m = spec.height_m;
    fs.center_m = {o.center_mm[0] * 1e-3, o.center_mm[1] * 1e-3, o.center_mm[2] * 1e-3};
    fs.min_delay_s = o.follow_delay_ms * 1e-3;
    follower = std::make_unique<LinuxcncFollower>(machine, fs);
    circle = follower->source();
    nominal_length_m = std::hypot(spec.radius_m, spec.height_m);
  } else {
    nominal_length_m = make_dbb_program(machine, specs, o.pause_s)->runs.front().nominal_length_m;
    player = std::make_shared<DbbProgramPlayer>(machine, specs, o.pause_s);
    circle = DbbProgramPlayer::source(player);
  }
  // The bus order: bar, the (first circle's) plane axes, the normal axis (served when a fourth node is given).
  const machine::Plane plane = specs.front().plane;
  const char* names[] = {"bar_length", plane == machine::Plane::yz ? "y" : "x", plane == machine::Plane::xy ? "y" : "z",
                         plane == machine::Plane::xy   ? "z"
                         : plane == machine::Plane::xz ? "y"
                                                       : "x"};
  // Following LinuxCNC, a fifth node serves the servo period being played (controller_period): a count is a
  // thousandth of a period, so a reading played between two periods says where between them it is.
  const std::size_t most = follower ? 5 : 4;
  if (nodes.size() > most)
    throw std::runtime_error("--nodes: at most " + std::to_string(most) + " nodes (bar, three axes" +
                             (follower ? ", controller_period)" : "; a fifth only with --follow)"));
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    drivers::dbb::EncoderScale e;
    e.channel = i < 4 ? names[i] : "controller_period";
    e.node_id = static_cast<std::uint8_t>(nodes[i]);
    e.resolution_m = i < 4 ? o.resolution_nm * 1e-9 : controller_period_resolution;
    if (i == 0) e.offset_m = std::round(nominal_length_m * 1e6) * 1e-6;  // the bar's nominal, in um
    settings.encoders.push_back(e);
  }
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
  if (follower) follower->start();
  const int rc = run_control_loop(
      [&](const auto& w, std::string& m) {
        if (follower && w[0] == "follow") {
          m = follower->status();
          return true;
        }
        if (w[0] == "circle") return retarget_circles(player.get(), w, m);
        return handle_fault(emu, w, m);
      },
      o.duration_s);
  emu.stop();
  if (follower) {
    follower->stop();
    std::printf("%s\n", follower->status().c_str());
  }
  return rc;
}

void add_dbb(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<DbbOptions>();
  auto* cmd =
      app.add_subcommand("dbb", "double ball bar + X/Y/Z encoders on CAN: CANopen nodes (CiA 301/406), TPDOs on SYNC");
  cmd->add_option("--bus", o->bus, "unix:PATH (SEQPACKET gateway to listen on) or can:IFNAME (SocketCAN)")
      ->capture_default_str();
  cmd->add_option("--fd", o->fd, "serve an inherited fd carrying can_frame records instead of --bus");
  cmd->add_option("--sync", o->sync, "answer the driver's SYNC, or produce SYNC like a controller")
      ->check(CLI::IsMember({"answer", "produce"}))
      ->capture_default_str();
  cmd->add_option("--sync-rate-hz", o->sync_rate_hz, "SYNC rate when producing")->capture_default_str();
  cmd->add_option("--nodes", o->nodes,
                  "node IDs of bar, first axis, second axis and (optional) the axis normal to the plane (z for xy; "
                  "three-plane: the next node when not given); with --follow a fifth: LinuxCNC's servo period being "
                  "played (channel controller_period, resolution_nm 1000000: a count is a thousandth of a period)")
      ->expected(3, 5)
      ->capture_default_str();
  cmd->add_option("--resolution-nm", o->resolution_nm, "encoder resolution (object 0x6005:1)")->capture_default_str();
  cmd->add_option("--heartbeat-ms", o->heartbeat_ms, "the nodes' producer heartbeat time at power-on (0x1017; 0: none)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  cmd->add_option(
         "--transmission-type", o->transmission_type,
         "TPDO1 transmission type at power-on (0x1800:2): 1 = every SYNC, n = every n-th, 254/255 = event-driven")
      ->check(CLI::Range(0, 255))
      ->capture_default_str();
  cmd->add_option("--serial-numbers", o->serial_numbers,
                  "serial numbers (0x1018:4) of bar, first axis, second axis "
                  "(default 1000 + node-ID)")
      ->expected(3, 4);
  cmd->add_flag("--auto-start", o->auto_start,
                "the nodes start themselves (operational after boot-up) instead of waiting for NMT start");
  cmd->add_option("--machine", o->machine_file,
                  "virtual machine tool file (default: config/machine-example.toml, compiled in)");
  cmd->add_option("--radius-mm", o->radius_mm, "circle radius")->capture_default_str();
  cmd->add_option("--height-mm", o->height_mm, "tool ball above the centre ball (Lai's h)")->capture_default_str();
  cmd->add_option("--feed-mm-min", o->feed_mm_min, "feed rate")->capture_default_str();
  cmd->add_option("--direction", o->direction, "ccw or cw")->check(CLI::IsMember({"ccw", "cw"}))->capture_default_str();
  cmd->add_option("--plane", o->plane, "circle plane")->check(CLI::IsMember({"xy", "xz", "yz"}))->capture_default_str();
  cmd->add_option("--overshoot-deg", o->overshoot_deg, "feed-in/feed-out arcs")->capture_default_str();
  cmd->add_option("--program", o->program,
                  "single: the circle of the options; standard: ccw then cw at h = 0 in the plane; three-plane: xy "
                  "360 deg, xz and yz 220 deg (z above the centre), ccw then cw each; lai: Lai's three patterns")
      ->check(CLI::IsMember({"single", "standard", "three-plane", "lai"}))
      ->capture_default_str();
  cmd->add_option("--pause-s", o->pause_s, "standing still after each circle")->capture_default_str();
  cmd->add_option("--follow", o->follow,
                  "move as LinuxCNC commands: the socket of guideway-linuxcnc-bridge (docs/linuxcnc.md); the bar is "
                  "set for --radius-mm, --height-mm, --plane about --center-mm");
  cmd->add_option("--follow-delay-ms", o->follow_delay_ms,
                  "with --follow: the least delay behind LinuxCNC's newest period (longer when the link is late)")
      ->check(CLI::Range(1.0, 5000.0))
      ->capture_default_str();
  cmd->add_option("--center-mm", o->center_mm, "with --follow: where the bar's fixed ball is (machine coordinates)")
      ->expected(3)
      ->capture_default_str();
  cmd->add_option("--duration-s", o->duration_s, "stop after this long (0: until quit/SIGTERM)")->capture_default_str();
  cmd->callback([o, &exit_code] { exit_code = run_dbb(*o); });
}

const EmulatorCommand registration(&add_dbb);

}  // namespace

}  // namespace guideway::simulators::emulators
