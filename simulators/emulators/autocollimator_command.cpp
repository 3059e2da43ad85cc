// `guideway-emulate autocollimator`: a TA80-style autocollimator on a pseudo-terminal watching a
// mirror on a carriage that traverses an axis of the virtual machine tool with stops every step; the
// reflector is lifted between stops, runs back over the same stops (--passes) and rests after the last
// (no reflection meanwhile), then the program repeats.
#include <csignal>
#include <cstdio>
#include <iostream>

#include "simulators/emulators/autocollimator_emulator.hpp"
#include "simulators/emulators/can_serial_control.hpp"
#include "simulators/emulators/can_serial_machine_sources.hpp"
#include "simulators/emulators/emulator_command.hpp"

namespace guideway::simulators::emulators {

namespace {

struct AutocollimatorOptions {
  std::string link;
  std::string machine_file;
  std::string axis = "x";
  double start_mm = 0.0;
  double end_mm = 600.0;
  double step_mm = 18.75;  // 33 stations a pass: EXPLAIN's structure tests need 32 readings
  std::size_t passes = 2;
  double dwell_s = 1.5;  // 2 s a station with the move: the example machine's drift of 0.1"/min is found
  double move_s = 0.5;
  double return_s = 1.5;
  double range_arcsec = 1000.0;
  bool checksum = false;
  double duration_s = 0.0;
};

bool handle_fault(AutocollimatorEmulator& emu, const std::vector<std::string>& w, std::string& msg) {
  int n = 1;
  double s = 0;
  const std::string& c = w[0];
  if (c == "disconnect") {
    if (w.size() > 1 && !word_to_double(w, 1, s)) return false;
    emu.inject_disconnect(s);
  } else if (c == "garbage" && word_to_int(w, 1, n)) {
    emu.inject_garbage(n);
  } else if (c == "truncated" && word_to_int(w, 1, n)) {
    emu.inject_truncated(n);
  } else if (c == "bad-checksum" && word_to_int(w, 1, n)) {
    emu.inject_bad_checksum(n);
  } else if (c == "stall" && word_to_double(w, 1, s)) {
    emu.inject_stall(s);
  } else if (c == "burst" && word_to_int(w, 1, n)) {
    emu.inject_burst(n);
  } else if (c == "block" && word_to_double(w, 1, s)) {
    emu.inject_block(s);
  } else if (c == "status") {
    msg = emu.pty_path() + ", " + std::to_string(emu.requests()) + " requests, " + std::to_string(emu.log().size()) +
          " readings";
  } else {
    msg =
        "commands: disconnect [DOWN_S] | garbage BYTES | truncated N | bad-checksum N | stall S | burst N | block S"
        " | status | quit";
    return false;
  }
  return true;
}

int run_autocollimator(const AutocollimatorOptions& o) {
  block_stop_signals();
  std::signal(SIGPIPE, SIG_IGN);  // a reader of our stdout that went away must not kill the emulator
  const machine::Machine machine(o.machine_file.empty() ? machine::default_machine_config()
                                                        : machine::load_machine_config(o.machine_file));
  machine::TraverseSpec spec;
  spec.axis = o.axis == "y" ? machine::Axis::y : o.axis == "z" ? machine::Axis::z : machine::Axis::x;
  spec.start_m = o.start_mm * 1e-3;
  spec.end_m = o.end_mm * 1e-3;
  spec.step_m = o.step_mm * 1e-3;
  spec.dwell_s = o.dwell_s;
  AutocollimatorEmulator emu({o.range_arcsec, o.checksum, o.link},
                             traverse_source(make_traverse_motion(machine, spec, o.move_s, o.return_s, o.passes)));
  emu.on_reopen([](const std::string& path) {
    std::printf("pty: %s\n", path.c_str());
    std::fflush(stdout);
  });
  std::string error;
  if (!emu.start(error)) throw std::runtime_error(error);
  if (!o.link.empty()) std::printf("link: %s\n", o.link.c_str());
  // Read by the daemon's emulator launcher: the stable link when there is one (it survives
  // disconnect faults), else the pty.
  std::printf("endpoint: pty:%s\n", emu.path().c_str());
  std::fflush(stdout);
  const int rc = run_control_loop([&](const auto& w, std::string& m) { return handle_fault(emu, w, m); }, o.duration_s);
  emu.stop();
  return rc;
}

void add_autocollimator(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<AutocollimatorOptions>();
  auto* cmd = app.add_subcommand("autocollimator",
                                 "TA80-style autocollimator on a pseudo-terminal (prints \"pty: /dev/pts/N\"), "
                                 "watching a traverse with stops");
  cmd->add_option("--link", o->link, "keep a symlink to the current pty here (survives disconnect faults)");
  cmd->add_option("--machine", o->machine_file,
                  "virtual machine tool file (default: config/machine-example.toml, compiled in)");
  cmd->add_option("--axis", o->axis, "traversed axis")->check(CLI::IsMember({"x", "y", "z"}))->capture_default_str();
  cmd->add_option("--start-mm", o->start_mm, "first station")->capture_default_str();
  cmd->add_option("--end-mm", o->end_mm, "last station")->capture_default_str();
  cmd->add_option("--step-mm", o->step_mm, "distance between stops")->capture_default_str();
  cmd->add_option("--passes", o->passes, "passes over the stations: forward, back, forward...")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_option("--dwell-s", o->dwell_s, "time at each stop")->capture_default_str();
  cmd->add_option("--move-s", o->move_s, "reflector lifted between stops (no reflection)")->capture_default_str();
  cmd->add_option("--return-s", o->return_s, "reflector carried back to the start after the last stop (no reflection)")
      ->capture_default_str();
  cmd->add_option("--range-arcsec", o->range_arcsec, "measuring range (beyond: OVER)")->capture_default_str();
  cmd->add_flag("--checksum", o->checksum, "append *HH checksums to replies");
  cmd->add_option("--duration-s", o->duration_s, "stop after this long (0: until quit/SIGTERM)")->capture_default_str();
  cmd->callback([o, &exit_code] { exit_code = run_autocollimator(*o); });
}

const EmulatorCommand registration(&add_autocollimator);

}  // namespace

}  // namespace guideway::simulators::emulators
