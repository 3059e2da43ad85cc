// `guideway program dbb`: the G-code program of a ballbar test, for the user to load into the controller
// (formats/dbb_program; docs/linuxcnc.md, "The test program").
#include <cmath>
#include <fstream>
#include <iostream>

#include "cli/commands.hpp"
#include "formats/dbb_program.hpp"

namespace guideway::cli {

namespace {

struct ProgramArgs {
  std::string test = "standard";
  double radius_mm = 100.0;
  double feed_mm_per_min = 1000.0;
  std::string plane = "xy";
  std::vector<double> center_mm{0.0, 0.0, 0.0};
  double overshoot_deg = 45.0;
  double start_deg = 0.0;
  double arc_deg = 360.0;
  std::string units = "mm";
  int session_pin = 0;
  bool no_session_pin = false;
  double pause_s = 1.0;
  bool no_stop = false;
  std::string out;
  void add(CLI::App& cmd) {
    cmd.add_option("--test", test,
                   "standard: ccw then cw, 360 deg, at h = 0 in --plane; three-plane: xy 360 deg, then xz and yz "
                   "220 deg above the centre, ccw then cw each (the tests of guideway start dbb --test)")
        ->check(CLI::IsMember({"standard", "three-plane"}))
        ->capture_default_str();
    cmd.add_option("--radius-mm", radius_mm, "the bar's length (h = 0)")->check(CLI::Range(1.0, 2000.0))
        ->capture_default_str();
    cmd.add_option("--feed-mm-per-min", feed_mm_per_min, "the feed on the circle")->check(CLI::Range(1.0, 60000.0))
        ->capture_default_str();
    cmd.add_option("--plane", plane, "the standard test's plane")->check(CLI::IsMember({"xy", "xz", "yz"}))
        ->capture_default_str();
    cmd.add_option("--center-mm", center_mm, "the circle's centre, machine coordinates (G53): the fixed ball")
        ->expected(3)
        ->capture_default_str();
    cmd.add_option("--overshoot-deg", overshoot_deg, "the feed-in and feed-out arcs (three-plane: at most 10 deg "
                                                     "in xz, yz)")
        ->check(CLI::Range(0.0, 90.0))
        ->capture_default_str();
    cmd.add_option("--start-deg", start_deg, "standard test: where the data arc starts")->capture_default_str();
    cmd.add_option("--arc-deg", arc_deg, "standard test: the data arc (180 to 360 deg; a partial arc ccw from "
                                         "--start-deg, cw back to it)")
        ->check(CLI::Range(180.0, 360.0))
        ->capture_default_str();
    cmd.add_option("--units", units, "the machine's units: mm (G21) or inch (G20); the options stay in mm")
        ->check(CLI::IsMember({"mm", "inch"}))
        ->capture_default_str();
    cmd.add_option("--session-pin", session_pin,
                   "motion.digital-out-NN raised over the test (M62/M65): guidewayd starts and ends the session on it")
        ->check(CLI::Range(0, 63))
        ->capture_default_str();
    cmd.add_flag("--no-session-pin", no_session_pin, "no M62/M65: the session is started by hand");
    cmd.add_option("--pause-s", pause_s, "dwell after each run")->check(CLI::Range(0.2, 600.0))->capture_default_str();
    cmd.add_flag("--no-stop", no_stop, "no M0 before a run to mount the bar (the bar stays mounted)");
    cmd.add_option("--out", out, "the program file (default: standard output)");
  }
};

void run_program_dbb(const ProgramArgs& a, CliContext& /*ctx*/) {
  formats::DbbProgram p;
  p.center_mm = {a.center_mm[0], a.center_mm[1], a.center_mm[2]};
  p.feed_mm_per_min = a.feed_mm_per_min;
  p.inch = a.units == "inch";
  p.pause_s = a.pause_s;
  p.session_pin = a.no_session_pin ? -1 : a.session_pin;
  p.stop_to_mount = !a.no_stop;
  try {
    p.circles = formats::dbb_test_circles(a.test, a.radius_mm, a.plane, a.overshoot_deg);
    if (a.test == "standard") {
      for (auto& c : p.circles) {
        c.data_arc_deg = a.arc_deg;
        // A partial arc runs ccw from the start and cw back to it: the same arc both ways.
        c.start_deg = c.ccw || a.arc_deg >= 360.0 ? a.start_deg : a.start_deg + a.arc_deg;
      }
    }
    p.title = "Guideway ballbar test: " + a.test + ", r " + std::to_string(std::lround(a.radius_mm)) + " mm, F" +
              std::to_string(std::lround(a.feed_mm_per_min)) + " mm/min, centre X" + std::to_string(a.center_mm[0]) +
              " Y" + std::to_string(a.center_mm[1]) + " Z" + std::to_string(a.center_mm[2]) + " mm";
    const std::string text = formats::format_dbb_program(p);
    if (a.out.empty()) {
      std::cout << text;
    } else {
      std::ofstream f(a.out);
      f << text;
      if (!f.flush()) throw std::runtime_error("cannot write " + a.out);
    }
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  std::cerr << "guideway program dbb: " << (a.out.empty() ? "written" : "wrote " + a.out) << ": " << p.circles.size()
            << " runs, about " << std::lround(formats::dbb_program_duration_s(p)) << " s of feed and dwell"
            << (p.session_pin >= 0 ? ", session pin motion.digital-out-" + std::to_string(p.session_pin) : "")
            << (p.stop_to_mount ? ", M0 to mount the bar before the first run of each plane" : "") << "\n";
}

void add_program_commands(CLI::App& app, CliContext& ctx) {
  auto* program = app.add_subcommand("program", "write the program of a test for the machine's controller");
  program->require_subcommand(1);
  add_commands(*program, ctx,
               {command("dbb",
                        "the G-code of a ballbar test (LinuxCNC RS274NGC): the standard CW/CCW circles or the "
                        "three-plane test, with feed-in/feed-out arcs (docs/linuxcnc.md)",
                        &run_program_dbb)});
}

const CommandGroup group(&add_program_commands);

}  // namespace

}  // namespace guideway::cli
