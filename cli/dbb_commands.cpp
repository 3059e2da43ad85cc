// `guideway identify dbb` and `guideway simulate dbb`: offline DBB identification (Lai's third-order
// model and ballbar diagnostics) and DBB runs from the virtual machine tool.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <numbers>

#include "cli/commands.hpp"
#include "cli/params_print.hpp"
#include "cli/progress.hpp"
#include "core/number_format.hpp"
#include "core/toml_access.hpp"
#include "models/dbb/json.hpp"
#include "models/explain/dbb_checked.hpp"
#include "results/parameters.hpp"
#include "simulators/machine/dbb_runs.hpp"

namespace guideway::cli {

namespace {

struct IdentifyArgs {
  std::vector<std::string> files;
  bool json = false, quiet = false;
  double period_a_mm = 0, period_b_mm = 0;
  bool per_run_center = false;
  bool without_explain = false;
  double bar_length_u_um = 0;
  void add(CLI::App& cmd) {
    cmd.add_option("runs", files, "DBB run files (guideway/dbb-run/1 CSV)")->required()->check(CLI::ExistingFile);
    cmd.add_option("--bar-length-u-um", bar_length_u_um,
                   "standard uncertainty of the bar's calibrated length (its certificate's u, k = 1; a device's "
                   "calibrated_length_u_um): added to every parameter's u as the fit's response to it")
        ->check(CLI::NonNegativeNumber);
    cmd.add_flag("--json", json, "print the result as one JSON object");
    cmd.add_flag("--quiet", quiet, "no progress lines on standard error (--json: none either)");
    cmd.add_option("--cyclic-period-a-mm", period_a_mm, "known lead of the first plane axis (default: search)");
    cmd.add_option("--cyclic-period-b-mm", period_b_mm, "known lead of the second plane axis (default: search)");
    cmd.add_flag("--per-run-center", per_run_center,
                 "Lai model: one centre offset per run instead of Lai's fixed socket shared by all patterns");
    cmd.add_flag("--without-explain", without_explain,
                 "the models alone: without fitting what EXPLAIN finds on the same runs beside their terms (a drift "
                 "then reads as backlash)");
  }
};

// One plane's identification as `compensate` and the live session make it (models/explain/dbb_checked):
// what EXPLAIN finds on the same runs and the models do not hold (a drift, a vibration) fitted beside their
// terms, so that it is not read as one of them; a term that still contradicts EXPLAIN is "not determined".
struct PlaneResult {
  models::dbb::Identification id;
  results::Params params;
};
PlaneResult identify_plane(const std::vector<formats::DbbRun>& runs, const models::dbb::IdentifyOptions& opt,
                           bool with_explain) {
  if (!with_explain) {
    PlaneResult out{models::dbb::identify(runs, opt), {}};
    out.params = models::dbb::to_params(out.id);
    return out;
  }
  const models::explain::CheckedIdentification checked = models::explain::identify_checked(runs, opt);
  return {checked.id, models::explain::to_params(checked)};
}

void run_identify(const IdentifyArgs& a, CliContext& /*ctx*/) {
  std::vector<formats::DbbRun> runs;
  for (const auto& f : a.files) runs.push_back(formats::read_dbb_run(f));
  models::dbb::IdentifyOptions opt;
  opt.cyclic_period_a_m = a.period_a_mm * 1e-3;
  opt.cyclic_period_b_m = a.period_b_mm * 1e-3;
  opt.lai_shared_center = !a.per_run_center;
  opt.bar_length_u_um = a.bar_length_u_um;
  std::vector<models::dbb::Identification> ids;
  std::vector<results::Params> plane_params;
  {
    Progress progress("identify", a.quiet || a.json);
    for (const auto& plane : models::dbb::runs_by_plane(std::move(runs))) {
      progress.doing("the " + plane.front().plane + " plane's " + std::to_string(plane.size()) + " run(s): " +
                     (a.without_explain ? "Lai's model and the ballbar diagnostics"
                                        : "Lai's model, the ballbar diagnostics and EXPLAIN beside them"));
      PlaneResult r = identify_plane(plane, opt, !a.without_explain);
      ids.push_back(std::move(r.id));
      plane_params.push_back(std::move(r.params));
    }
  }
  if (ids.size() == 1) {
    const results::Params& p = plane_params.front();
    if (a.json) {
      std::cout << results::to_json(p).dump() << "\n";
    } else {
      std::cout << "DBB identification (" << ids.front().model << "), " << ids.front().runs.size() << " run(s), "
                << ids.front().plane << " plane\n";
      print_result(p);
    }
    return;
  }
  // Several planes: each plane's identification, then the machine across them.
  const results::DbbPlanesSummary summary = models::dbb::planes_record(models::dbb::summarize_planes(ids));
  if (a.json) {
    nlohmann::json j = {{"planes", nlohmann::json::object()}, {"summary", results::to_json(summary)}};
    for (std::size_t k = 0; k < ids.size(); ++k) j["planes"][ids[k].plane] = results::to_json(plane_params[k]);
    std::cout << j.dump() << "\n";
    return;
  }
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const auto& id = ids[k];
    std::cout << "== " << id.plane << " plane: DBB identification (" << id.model << "), " << id.runs.size()
              << " run(s)\n";
    print_result(plane_params[k]);
    std::cout << "\n";
  }
  print_planes_summary(summary);
}

struct SimulateArgs {
  std::string machine, out, direction = "ccw", plane = "xy";
  double radius_mm = 100, height_mm = 0, feed = 1000, start_deg = 0, overshoot_deg = 45, rate = 0, t0 = 0;
  double arc_deg = 360;
  std::vector<double> gap_s;
  std::vector<double> center_mm;
  std::uint64_t seed = 0;
  CLI::Option* t0_option = nullptr;
  void add(CLI::App& cmd) {
    cmd.add_option("--machine", machine, "machine file (TOML, see docs/machine.md)")
        ->required()
        ->check(CLI::ExistingFile);
    cmd.add_option("--radius-mm", radius_mm, "circle radius")->required()->check(CLI::PositiveNumber);
    cmd.add_option("--height-mm", height_mm, "socket height h (Lai), 0 for an in-plane bar")
        ->check(CLI::NonNegativeNumber);
    cmd.add_option("--direction", direction, "ccw or cw")->check(CLI::IsMember({"ccw", "cw"}));
    cmd.add_option("--feed-mm-per-min", feed, "feed rate (default 1000)")->check(CLI::PositiveNumber);
    cmd.add_option("--plane", plane, "xy, xz or yz (default xy)")->check(CLI::IsMember({"xy", "xz", "yz"}));
    cmd.add_option("--start-deg", start_deg, "start angle of the data arc (default 0)");
    cmd.add_option("--arc-deg", arc_deg,
                   "data arc (default 360; a partial arc of 180 deg or more, e.g. 220 from --start-deg -20 in a "
                   "vertical plane)")
        ->check(CLI::Range(180.0, 360.0));
    cmd.add_option("--gap-s", gap_s,
                   "drop the samples of a dropout: START DURATION (s from the first sample of the data arc)")
        ->expected(2);
    cmd.add_option("--overshoot-deg", overshoot_deg, "feed-in/feed-out arcs (default 45)")
        ->check(CLI::NonNegativeNumber);
    cmd.add_option("--sample-rate-hz", rate, "bar sampling rate (default: 10 samples per degree)");
    cmd.add_option("--center-mm", center_mm, "circle centre in machine coordinates: X Y Z")->expected(3);
    t0_option = cmd.add_option("--t0-s", t0,
                               "machine time at the start (thermal drift); the run file then carries start_time_s, so "
                               "runs simulated with --t0-s share one machine clock");
    cmd.add_option("--seed", seed, "noise seed (default: the machine file's)");
    cmd.add_option("--out", out, "run file to write")->required();
  }
};

simulators::machine::DbbCircleSpec circle_spec(const SimulateArgs& a) {
  constexpr double deg = std::numbers::pi / 180.0;
  simulators::machine::DbbCircleSpec spec;
  spec.radius_m = a.radius_mm * 1e-3;
  spec.height_m = a.height_mm * 1e-3;
  spec.direction = a.direction == "cw" ? formats::DbbDirection::cw : formats::DbbDirection::ccw;
  spec.plane = a.plane == "xz" ? simulators::machine::Plane::xz
                               : (a.plane == "yz" ? simulators::machine::Plane::yz : simulators::machine::Plane::xy);
  spec.feed_m_per_s = a.feed * 1e-3 / 60.0;
  spec.start_angle_rad = a.start_deg * deg;
  spec.overshoot_rad = a.overshoot_deg * deg;
  spec.data_arc_rad = a.arc_deg * deg;
  spec.sample_rate_hz = a.rate;
  if (a.center_mm.size() == 3) spec.center = {a.center_mm[0] * 1e-3, a.center_mm[1] * 1e-3, a.center_mm[2] * 1e-3};
  spec.t0_s = a.t0;
  spec.seed = a.seed;
  return spec;
}

void run_simulate(const SimulateArgs& a, CliContext& /*ctx*/) {
  const simulators::machine::Machine machine = simulators::machine::Machine::from_file(a.machine);
  auto run = simulators::machine::simulate_dbb_run(machine, circle_spec(a), a.out);
  // Without --t0-s every run would start at machine time 0: no common clock is claimed.
  if (a.t0_option->count() == 0) run.metadata.erase("start_time_s");
  if (a.gap_s.size() == 2) run = simulators::machine::with_dropout(run, a.gap_s[0], a.gap_s[1]);
  // A test condition the standards' figures state (models/dbb/standard_figures.hpp).
  run.metadata["overshoot_deg"] = significant_digits(a.overshoot_deg, 6);
  formats::write_dbb_run(run, a.out);
  std::cout << "wrote " << a.out << ": " << run.angle_rad.size() << " samples, r " << a.radius_mm << " mm, h "
            << a.height_mm << " mm, " << a.direction << "\n";
}

void add_dbb_commands(CLI::App& app, CliContext& ctx) {
  add_commands(*identify_command(app), ctx,
               {command("dbb", "DBB circular tests: Lai third-order model and ballbar diagnostics", &run_identify)});
  add_commands(*shared_subcommand(app, "simulate", "Produce runs from the virtual machine tool"), ctx,
               {command("dbb", "Write a DBB run traced by the virtual machine tool", &run_simulate)});
}

const CommandGroup dbb_group(&add_dbb_commands);

}  // namespace

}  // namespace guideway::cli
