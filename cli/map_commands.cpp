// `guideway map`: one error map of the machine (the 21 errors of ISO 230-1) from a day's tests, its volumetric
// accuracy and the tables a controller loads; `guideway simulate day`: the day's test files from a machine file
// (docs/map.md). `guideway compensate map` is in compensate_map_commands.cpp.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli/commands.hpp"
#include "cli/map_support.hpp"
#include "cli/params_print.hpp"
#include "cli/progress.hpp"
#include "core/number_format.hpp"
#include "models/map/day.hpp"
#include "models/map/exports.hpp"
#include "models/map/map_json.hpp"
#include "simulators/emulators/day_files.hpp"

namespace guideway::cli {

namespace {

namespace fs = std::filesystem;

// ---- guideway simulate day ----

struct SimulateDayArgs {
  std::string machine, out_dir;
  std::vector<double> travel_mm;
  std::string planes = "xy,xz,yz", traverse = "xyz", artifact = "xyz";
  bool no_runout = false;
  double radius_mm = 100;
  std::size_t targets = 9;
  std::uint64_t seed = 0;
  void add(CLI::App& cmd) {
    cmd.add_option("--machine", machine, "machine file (TOML, docs/machine.md)")->required()->check(CLI::ExistingFile);
    cmd.add_option("--out-dir", out_dir, "directory for the day's files and day.json (created)")->required();
    cmd.add_option("--travel-mm", travel_mm,
                   "the volume the tests cover: X_LO X_HI Y_LO Y_HI Z_LO Z_HI (default -200 200 -200 200 -150 150)")
        ->expected(6);
    cmd.add_option("--planes", planes, "ballbar planes, comma separated (xy,xz,yz; \"\" for none)")->capture_default_str();
    cmd.add_option("--traverse", traverse, "axes traversed with the autocollimator (e.g. xy; \"\" for none)")
        ->capture_default_str();
    cmd.add_option("--artifact", artifact, "axes measured with the 1-D artifact (e.g. x; \"\" for none)")
        ->capture_default_str();
    cmd.add_flag("--no-runout", no_runout, "leave out the run-out plate");
    cmd.add_option("--radius-mm", radius_mm, "ballbar radius")->check(CLI::PositiveNumber)->capture_default_str();
    cmd.add_option("--targets", targets, "artifact targets over the travel")->check(CLI::Range(3, 100))->capture_default_str();
    cmd.add_option("--seed", seed, "noise seed (default: the machine file's)");
  }
};

std::array<bool, 3> axes_of(const std::string& text, const char* what) {
  std::array<bool, 3> on{};
  for (char c : text) {
    if (c == ',' || c == ' ') continue;
    if (c < 'x' || c > 'z') throw std::runtime_error(std::string(what) + ": '" + text + "' (axes x, y, z)");
    on[static_cast<std::size_t>(c - 'x')] = true;
  }
  return on;
}

void run_simulate_day(const SimulateDayArgs& a, CliContext& /*ctx*/) {
  const simulators::machine::Machine machine = simulators::machine::Machine::from_file(a.machine);
  simulators::emulators::DayPlan plan;
  if (a.travel_mm.size() == 6)
    for (std::size_t j = 0; j < 3; ++j) {
      if (!(a.travel_mm[2 * j + 1] > a.travel_mm[2 * j]))
        throw std::runtime_error("--travel-mm: each axis' LO must be below its HI");
      plan.travel_m[j] = {a.travel_mm[2 * j] * 1e-3, a.travel_mm[2 * j + 1] * 1e-3};
    }
  plan.planes.clear();
  std::stringstream ps(a.planes);
  for (std::string p; std::getline(ps, p, ',');) {
    if (p.empty()) continue;
    if (p != "xy" && p != "xz" && p != "yz") throw std::runtime_error("--planes: '" + p + "' (xy, xz, yz)");
    plan.planes.push_back(p);
  }
  plan.traverse = axes_of(a.traverse, "--traverse");
  plan.artifact = axes_of(a.artifact, "--artifact");
  plan.runout = !a.no_runout;
  plan.ballbar_radius_m = a.radius_mm * 1e-3;
  plan.artifact_targets = a.targets;
  plan.seed = a.seed;
  fs::create_directories(a.out_dir);
  Progress progress("simulate day", false);
  progress.doing("tracing the day's tests on " + a.machine);
  const auto tests = simulators::emulators::write_day_files(machine, plan, a.out_dir);
  for (const auto& t : tests) {
    std::cout << t.kind << (t.where.empty() ? "" : " " + t.where) << ":";
    for (const auto& f : t.files) std::cout << " " << (fs::path(a.out_dir) / f).string();
    std::cout << "\n";
  }
  std::cout << "wrote " << (fs::path(a.out_dir) / "day.json").string() << " (" << tests.size()
            << " tests); what they determine: guideway map fit --day " << (fs::path(a.out_dir) / "day.json").string()
            << "\n";
}

// ---- guideway map fit ----

struct FitArgs {
  std::string day, out, report;
  std::vector<std::string> dbb, traverse, artifact, runout;
  std::vector<double> artifact_other_mm, tool_offset_mm, travel_mm;
  bool latest = false, json = false, quiet = false;
  std::size_t grid = 11;
  void add(CLI::App& cmd) {
    cmd.add_option("--day", day, "the day's manifest (day.json, format guideway/map-day/1)")->check(CLI::ExistingFile);
    cmd.add_option("--dbb", dbb, "ballbar run files (any planes)")->check(CLI::ExistingFile);
    cmd.add_option("--traverse", traverse, "autocollimator traverse files (their `# axis`)")->check(CLI::ExistingFile);
    cmd.add_option("--artifact", artifact,
                   "1-D artifact directories (calibration.csv, horizontal.csv, vertical.csv; their `# axis`)")
        ->check(CLI::ExistingDirectory);
    cmd.add_option("--artifact-other-mm", artifact_other_mm,
                   "where the artifacts lay: the other axes' positions X Y Z (default 0 0 0)")
        ->expected(3);
    cmd.add_option("--runout", runout, "run-out revolutions (a cross-check of the XZ squareness)")
        ->check(CLI::ExistingFile);
    cmd.add_flag("--latest", latest,
                 "the daemon's latest DBB, straightness (one per axis) and runout sessions, besides any files");
    cmd.add_option("--tool-offset-mm", tool_offset_mm, "the tool the tests were made with, X Y Z in the Z carriage frame")
        ->expected(3);
    cmd.add_option("--travel-mm", travel_mm, "the map's volume: X_LO X_HI Y_LO Y_HI Z_LO Z_HI (default: what the tests covered)")
        ->expected(6);
    cmd.add_option("--out", out, "write the map (guideway/map/1 JSON) here");
    cmd.add_option("--report", report, "write an HTML report of the map here");
    cmd.add_option("--grid", grid, "volumetric accuracy: grid points per axis")->check(CLI::Range(2, 41))->capture_default_str();
    cmd.add_flag("--json", json, "print the result as one JSON object");
    cmd.add_flag("--quiet", quiet, "no progress lines on standard error");
  }
};

void run_fit(const FitArgs& a, CliContext& ctx) {
  Progress progress("map", a.quiet || a.json);
  progress.doing("reading the day's tests");
  models::map::MapInputs in;
  if (!a.day.empty()) in = models::map::day_inputs(models::map::read_day(a.day));
  models::map::Vec3 other{};
  if (a.artifact_other_mm.size() == 3)
    other = {a.artifact_other_mm[0] * 1e-3, a.artifact_other_mm[1] * 1e-3, a.artifact_other_mm[2] * 1e-3};
  add_file_inputs(in, a.dbb, a.traverse, a.artifact, other, a.runout);
  if (a.latest) {
    progress.doing("asking the daemon for its latest sessions");
    add_latest_inputs(in, ctx.socket, std::cerr);
  }
  if (a.tool_offset_mm.size() == 3)
    in.tool_offset_m = {a.tool_offset_mm[0] * 1e-3, a.tool_offset_mm[1] * 1e-3, a.tool_offset_mm[2] * 1e-3};
  if (a.travel_mm.size() == 6) {
    std::array<models::map::Travel, 3> t{};
    for (std::size_t j = 0; j < 3; ++j) {
      if (!(a.travel_mm[2 * j + 1] > a.travel_mm[2 * j]))
        throw std::runtime_error("--travel-mm: each axis' LO must be below its HI");
      t[j] = {a.travel_mm[2 * j] * 1e-3, a.travel_mm[2 * j + 1] * 1e-3};
    }
    in.travel = t;
  }
  if (in.artifacts.empty() && in.traverses.empty() && in.ballbar_runs.empty())
    throw std::runtime_error("map fit: no tests (give --day, --dbb, --traverse, --artifact or --latest)");
  progress.doing("fitting the map to " + std::to_string(in.ballbar_runs.size()) + " ballbar runs, " +
                 std::to_string(in.traverses.size()) + " traverses and " + std::to_string(in.artifacts.size()) +
                 " artifacts");
  const models::map::MapFit fit = models::map::fit_map(in);
  progress.doing("volumetric accuracy over the volume");
  models::map::VolumetricOptions vo;
  vo.points = {a.grid, a.grid, a.grid};
  const auto va = models::map::volumetric_accuracy(fit.map, vo);
  const nlohmann::json j = models::map::to_json(fit, va);
  if (!a.out.empty()) write_text_file(a.out, j.dump(1) + "\n");
  if (!a.report.empty()) {
    progress.doing("writing the report");
    write_map_report(j, a.report);
  }
  progress.doing("");
  if (a.json) {
    std::cout << j.dump() << "\n";
    return;
  }
  print_map(j);
  if (!a.out.empty()) std::cout << "wrote " << a.out << "\n";
  if (!a.report.empty()) std::cout << "wrote " << a.report << "\n";
}

// ---- guideway map export ----

struct ExportArgs {
  std::string map, out_dir;
  double step_mm = 0;
  void add(CLI::App& cmd) {
    cmd.add_option("map", map, "the map (guideway/map/1 JSON)")->required()->check(CLI::ExistingFile);
    cmd.add_option("--out-dir", out_dir, "directory for the tables (created)")->required();
    cmd.add_option("--step-mm", step_mm, "table spacing (default: the finest round step within 256 lines)")
        ->check(CLI::PositiveNumber);
  }
};

void run_export(const ExportArgs& a, CliContext& /*ctx*/) {
  const auto written = export_map(a.map, a.out_dir, a.step_mm * 1e-3);
  for (const auto& f : written) std::cout << "wrote " << f << "\n";
}

// ---- guideway map volumetric ----

struct VolumetricArgs {
  std::string map;
  std::vector<double> tool_offset_mm;
  std::size_t grid = 11;
  bool json = false;
  void add(CLI::App& cmd) {
    cmd.add_option("map", map, "the map (guideway/map/1 JSON)")->required()->check(CLI::ExistingFile);
    cmd.add_option("--tool-offset-mm", tool_offset_mm, "another tool: X Y Z in the Z carriage frame (default: the map's)")
        ->expected(3);
    cmd.add_option("--grid", grid, "grid points per axis")->check(CLI::Range(2, 41))->capture_default_str();
    cmd.add_flag("--json", json, "print the result as one JSON object");
  }
};

void run_volumetric(const VolumetricArgs& a, CliContext& /*ctx*/) {
  const models::map::ErrorMap m = models::map::read_map(a.map);
  models::map::VolumetricOptions vo;
  vo.points = {a.grid, a.grid, a.grid};
  if (a.tool_offset_mm.size() == 3)
    vo.tool_offset_m = models::map::Vec3{a.tool_offset_mm[0] * 1e-3, a.tool_offset_mm[1] * 1e-3, a.tool_offset_mm[2] * 1e-3};
  const auto va = models::map::volumetric_accuracy(m, vo);
  const nlohmann::json j = models::map::to_json(va);
  if (a.json) {
    std::cout << j.dump() << "\n";
    return;
  }
  print_volumetric(j, "volumetric accuracy of " + a.map);
}

void add_map_commands(CLI::App& app, CliContext& ctx) {
  add_commands(*shared_subcommand(app, "simulate", "Produce runs from the virtual machine tool"), ctx,
               {command("day", "the whole day's test files of the error map from a machine file (docs/map.md)",
                        &run_simulate_day)});
  auto* map = app.add_subcommand("map", "One error map of the machine: the 21 errors from a day's tests (docs/map.md)");
  add_commands(*map, ctx,
               {command("fit", "fit the map to a day's tests: the 21 errors, what they cannot determine, cross-checks, "
                               "volumetric accuracy",
                        &run_fit),
                command("export", "the map as controller tables: ISO 230-1 tables, LinuxCNC per-joint tables, CSV",
                        &run_export),
                command("volumetric", "the map's volumetric accuracy (another tool offset, another grid)",
                        &run_volumetric)});
  add_map_sequence_command(*map, ctx);
  map->require_subcommand(1);
}

const CommandGroup group(&add_map_commands);

}  // namespace

}  // namespace guideway::cli
