// `guideway map sequence`: the tests of the error map on the daemon as one guided sequence (docs/map.md "On the
// daemon"): which test is done (the daemon's latest session of each), which comes next and how to set it up,
// what the map can and cannot determine with what is done; with --run the missing tests one after the other,
// each started on the daemon and followed with its progress, then the map.
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>
#include <set>

#include "cli/daemon_client.hpp"
#include "cli/map_support.hpp"
#include "cli/params_print.hpp"
#include "cli/session_wait.hpp"
#include "core/number_format.hpp"
#include "formats/dbb_run.hpp"
#include "models/map/fit.hpp"
#include "models/map/map_json.hpp"
#include "models/map/volumetric.hpp"
#include "results/message_class.hpp"
#include "results/result_header.hpp"
#include "results/session_kinds.hpp"

namespace guideway::cli {

namespace {

namespace fs = std::filesystem;
namespace mm = models::map;

struct SequenceArgs {
  bool run = false, redo = false, no_runout = false, no_ballbar = false;
  std::vector<double> travel_mm;
  double traverse_step_mm = 0;
  std::vector<std::string> artifacts;
  std::vector<double> artifact_other_mm;
  std::vector<std::string> traverse_devices;
  std::string ballbar_device, runout_device, out, report;
  double timeout_s = 1800;
  void add(CLI::App& cmd) {
    cmd.add_flag("--run", run, "run the tests not done yet, one after the other, then fit the map");
    cmd.add_flag("--redo", redo, "with --run: run every test again, done or not");
    cmd.add_flag("--no-runout", no_runout, "leave out the run-out plate (a cross-check of the XZ squareness)");
    cmd.add_flag("--no-ballbar", no_ballbar, "leave out the ballbar (the squarenesses are then not determined)");
    cmd.add_option("--travel-mm", travel_mm,
                   "where each traverse starts: X_LO X_HI Y_LO Y_HI Z_LO Z_HI (its first station at LO; default: the "
                   "session's start_mm)")
        ->expected(6);
    cmd.add_option("--traverse-step-mm", traverse_step_mm, "the traverses' station spacing (default: the session's)");
    cmd.add_option("--artifact", artifacts, "1-D artifact directories measured offline (their `# axis`)")
        ->check(CLI::ExistingDirectory);
    cmd.add_option("--artifact-other-mm", artifact_other_mm, "where the artifacts lay: X Y Z (default 0 0 0)")->expected(3);
    cmd.add_option("--traverse-devices", traverse_devices,
                   "the autocollimator device for X, Y and Z (one name for all, or three; default: the daemon's first)")
        ->expected(1, 3);
    cmd.add_option("--ballbar-device", ballbar_device, "the DBB device (default: the daemon's first)");
    cmd.add_option("--runout-device", runout_device, "the micrometer device (default: the daemon's first)");
    cmd.add_option("--timeout", timeout_s, "with --run: give up on a test after this many seconds")->capture_default_str();
    cmd.add_option("--out", out, "write the map here (guideway/map/1 JSON)");
    cmd.add_option("--report", report, "write the map's HTML report here");
  }
};

struct Step {
  std::string kind;  // session kind
  std::string axis;  // straightness
  std::string title;
  std::string setup;  // what the user sets up before it
  nlohmann::json options = nlohmann::json::object();
  std::string device;
  std::string done;  // the session that did it ("" = not yet)
};

std::vector<Step> steps_of(const SequenceArgs& a) {
  std::vector<Step> s;
  if (!a.no_ballbar) {
  Step dbb{std::string(results::dbb_kind.name), "", "ballbar in three planes (XY full circle, XZ and YZ 220 deg arcs, "
                                                     "CCW and CW)",
           "the ballbar's fixed ball at the volume's centre, the tool ball in the spindle; the three-plane program "
           "ready on the controller",
           {{std::string(results::dbb_test.name), "three-plane"}}, a.ballbar_device, ""};
    s.push_back(dbb);
  }
  for (int k = 0; k < 3; ++k) {
    const std::string ax = mm::axis_name(k);
    std::string device;
    if (a.traverse_devices.size() == 1) device = a.traverse_devices[0];
    if (a.traverse_devices.size() == 3) device = a.traverse_devices[static_cast<std::size_t>(k)];
    s.push_back({std::string(results::straightness_kind.name), ax,
                 "autocollimator traverse of " + std::string(1, "XYZ"[k]) + " (its pitch and yaw)",
                 "the autocollimator's beam along " + std::string(1, "XYZ"[k]) + ", the reflector on the " +
                     std::string(1, "XYZ"[k]) + " carriage; the traverse program ready (forward and back)",
                 {{std::string(results::straightness_axis.name), ax}}, device, ""});
    if (a.travel_mm.size() == 6)
      s.back().options[std::string(results::straightness_start_mm.name)] = a.travel_mm[static_cast<std::size_t>(2 * k)];
    if (a.traverse_step_mm > 0) s.back().options[std::string(results::straightness_step_mm.name)] = a.traverse_step_mm;
  }
  if (!a.no_runout)
    s.push_back({std::string(results::runout_kind.name), "", "run-out plate (a cross-check of the XZ squareness)",
                 "the inductance micrometer on the spindle touching the thrust plate", nlohmann::json::object(),
                 a.runout_device, ""});
  return s;
}

// The session of the daemon's latest PARAMS for a step, "" when there is none (or, for the ballbar, when its runs
// do not cover the three planes).
std::string latest_session(DaemonClient& c, const Step& s) {
  nlohmann::json req = {{"kind", s.kind}};
  if (!s.axis.empty()) req["axis"] = s.axis;
  const nlohmann::json r = c.request(results::request(results::RequestClass::params, req), results::MessageClass::params);
  if (results::has_class(r, results::MessageClass::error)) return {};
  const results::ResultHeader header = results::read_header(r);
  if (s.kind == results::dbb_kind.name) {
    std::set<std::string> planes;
    for (const std::string& f : header.derived) {
      if (fs::path(f).extension() != ".csv") continue;
      try {
        planes.insert(formats::read_dbb_run(f).plane);
      } catch (const std::exception&) {
        // not a run file
      }
    }
    if (planes.size() < 3) return {};
  }
  return header.session;
}

void print_plan(const std::vector<Step>& steps, const SequenceArgs& a) {
  std::cout << "the tests of the error map on the daemon:\n";
  for (std::size_t k = 0; k < steps.size(); ++k)
    std::cout << "  " << k + 1 << ". " << steps[k].title << ": "
              << (steps[k].done.empty() ? "not yet" : "done (session " + steps[k].done + ")") << "\n";
  std::cout << "  offline: the 1-D artifact on each axis (guideway-emulate artifact / Wei's artifact): "
            << (a.artifacts.empty() ? "not given (--artifact DIR): positioning, straightness and roll need it"
                                    : std::to_string(a.artifacts.size()) + " given")
            << "\n";
  for (const auto& s : steps)
    if (s.done.empty()) {
      std::cout << "next: " << s.title << "\n  set up: " << s.setup << "\n  run: guideway start " << s.kind;
      for (const auto& [k, v] : s.options.items())
        std::cout << " --set " << k << "=" << (v.is_string() ? v.get<std::string>() : v.dump());
      if (!s.device.empty()) std::cout << " --device " << s.device;
      std::cout << " --wait   (or: guideway map sequence --run)\n";
      return;
    }
  std::cout << "every test of the sequence is done\n";
}

void run_step(DaemonClient& c, Step& s, std::size_t k, std::size_t n, double timeout_s) {
  std::cout << "test " << k << " of " << n << ": " << s.title << "\n  set up: " << s.setup << "\n" << std::flush;
  nlohmann::json req = results::request(results::RequestClass::start, {{"kind", s.kind}, {"options", s.options}});
  if (!s.device.empty()) req["device"] = s.device;
  const nlohmann::json r = c.request(req, results::MessageClass::session);
  throw_if_error(r);
  const std::string session = r.value("session", "");
  std::cout << "  session " << session << " started\n" << std::flush;
  wait_for_params(c, session, timeout_s, false, false, false);
  s.done = session;
  std::cout << "  done\n";
}

void run_sequence(const SequenceArgs& a, CliContext& ctx) {
  std::vector<Step> steps = steps_of(a);
  DaemonClient c = connect_daemon(ctx.socket);
  for (auto& s : steps) s.done = a.redo ? std::string() : latest_session(c, s);
  print_plan(steps, a);
  if (a.run) {
    watch_session_progress(c);
    std::size_t k = 0;
    const std::size_t todo = static_cast<std::size_t>(
        std::count_if(steps.begin(), steps.end(), [](const Step& s) { return s.done.empty(); }));
    for (auto& s : steps)
      if (s.done.empty()) run_step(c, s, ++k, todo, a.timeout_s);
  }
  // What the map can tell from what is done.
  mm::MapInputs in;
  mm::Vec3 other{};
  if (a.artifact_other_mm.size() == 3)
    other = {a.artifact_other_mm[0] * 1e-3, a.artifact_other_mm[1] * 1e-3, a.artifact_other_mm[2] * 1e-3};
  add_file_inputs(in, {}, {}, a.artifacts, other, {});
  add_latest_inputs(in, ctx.socket, std::cerr);
  if (in.ballbar_runs.empty() && in.traverses.empty() && in.artifacts.empty()) {
    std::cout << "no test done yet: nothing to fit\n";
    return;
  }
  const mm::MapFit fit = mm::fit_map(in);
  const auto va = mm::volumetric_accuracy(fit.map);
  const nlohmann::json j = mm::to_json(fit, va);
  std::cout << "\nthe map from the tests done so far:\n";
  print_map(j);
  if (!a.out.empty()) {
    write_text_file(a.out, j.dump(1) + "\n");
    std::cout << "wrote " << a.out << "\n";
  }
  if (!a.report.empty()) {
    write_map_report(j, a.report);
    std::cout << "wrote " << a.report << "\n";
  }
}

}  // namespace

void add_map_sequence_command(CLI::App& map, CliContext& ctx) {
  add_commands(map, ctx,
               {command("sequence",
                        "the map's tests on the daemon as one guided sequence: done, next, what is still missing "
                        "(--run: run them)",
                        &run_sequence)});
}

}  // namespace guideway::cli
