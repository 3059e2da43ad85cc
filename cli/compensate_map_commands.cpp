// `guideway compensate map MAP.json --out-dir DIR [--verify --machine FILE]`: the error map's tables (ISO 230-1
// volumetric tables, LinuxCNC per-joint tables and what a per-axis controller takes of the rest), and with
// --verify the virtual machine tool with them loaded: its volumetric accuracy before and after, measured on the
// machine itself (docs/map.md "Compensation").
#include <filesystem>
#include <iostream>

#include "cli/commands.hpp"
#include "cli/map_support.hpp"
#include "cli/progress.hpp"
#include "core/number_format.hpp"
#include "formats/compensation_files.hpp"
#include "models/map/exports.hpp"
#include "models/map/map_json.hpp"
#include "models/map/volumetric.hpp"
#include "simulators/machine/dbb_runs.hpp"
#include "simulators/machine/map_truth.hpp"

namespace guideway::cli {

namespace {

namespace fs = std::filesystem;
namespace mm = models::map;
namespace sm = simulators::machine;

struct Args {
  std::string map, out_dir, machine;
  double step_mm = 0;
  bool verify = false, json = false, quiet = false;
  std::size_t grid = 11;
  void add(CLI::App& cmd) {
    cmd.add_option("map", map, "the map (guideway/map/1 JSON, guideway map fit --out)")->required()->check(CLI::ExistingFile);
    cmd.add_option("--out-dir", out_dir, "directory for the tables (created)")->required();
    cmd.add_option("--step-mm", step_mm, "table spacing (default: the finest round step within 256 lines)")
        ->check(CLI::PositiveNumber);
    cmd.add_flag("--verify", verify,
                 "load the tables into the virtual machine tool and measure its volumetric accuracy before and after");
    cmd.add_option("--machine", machine, "with --verify: the machine file (docs/machine.md)")->check(CLI::ExistingFile);
    cmd.add_option("--grid", grid, "with --verify: grid points per axis")->check(CLI::Range(2, 41))->capture_default_str();
    cmd.add_flag("--json", json, "print the result as one JSON object");
    cmd.add_flag("--quiet", quiet, "no progress lines on standard error");
  }
};

// The machine's own volumetric accuracy over the map's grid, with the controller's corrections.
mm::VolumetricAccuracy measured(const sm::Machine& machine, const std::vector<mm::Vec3>& at,
                                const sm::ControllerCorrection& correction) {
  std::vector<mm::Vec3> e;
  e.reserve(at.size());
  for (const auto& p : at) e.push_back(sm::static_tool_error(machine, p, correction));
  return mm::field_accuracy(at, e);
}

void run(const Args& a, CliContext& /*ctx*/) {
  if (a.verify && a.machine.empty()) throw std::runtime_error("compensate map: --verify needs --machine FILE");
  Progress progress("compensate", a.quiet || a.json);
  progress.doing("writing the tables");
  const auto written = export_map(a.map, a.out_dir, a.step_mm * 1e-3);
  nlohmann::json j = {{"files", written}};
  if (a.verify) {
    progress.doing("the virtual machine with the tables loaded");
    const mm::ErrorMap m = mm::read_map(a.map);
    const sm::Machine machine = sm::Machine::from_file(a.machine);
    const auto at = mm::volume_grid(m.travel, {a.grid, a.grid, a.grid});
    // The volumetric compensation reads its tables back, as a controller would load them.
    const mm::TableMap tables = mm::read_table_map(a.out_dir);
    const mm::Vec3 tool = machine.config().tool_offset;
    sm::ControllerCorrection volumetric;
    volumetric.volumetric = [tables, tool](const sm::Vec3& p) {
      const mm::Vec3 e = mm::table_tool_error(tables, p, tool);
      return sm::Vec3{-e[0], -e[1], -e[2]};
    };
    // What LinuxCNC loads: the per-joint tables; and with a cross-axis compensation, straightness.csv.
    sm::ControllerCorrection joints;
    for (std::size_t k = 0; k < 3; ++k)
      joints.tables[k] = sm::joint_compensation(
          formats::read_linuxcnc_comp((fs::path(a.out_dir) / (std::string(1, "xyz"[k]) + ".comp")).string()));
    sm::ControllerCorrection joints_cross = joints;
    joints_cross.cross = sm::cross_compensation(
        formats::read_straightness_csv((fs::path(a.out_dir) / "straightness.csv").string()));
    const auto before = measured(machine, at, {});
    const auto after = measured(machine, at, volumetric);
    const auto after_joints = measured(machine, at, joints);
    const auto after_cross = measured(machine, at, joints_cross);
    const bool pass = after.value_m <= before.value_m / 3.0;
    j["verify"] = {{"machine", a.machine},
                   {"before", mm::to_json(before)},
                   {"after_volumetric", mm::to_json(after)},
                   {"after_linuxcnc_joints", mm::to_json(after_joints)},
                   {"after_joints_and_straightness", mm::to_json(after_cross)},
                   {"ratio", after.value_m / before.value_m},
                   {"at_most_a_third", pass}};
    progress.doing("");
    if (!a.json) {
      std::cout << "verified on the virtual machine " << a.machine << " (" << at.size()
                << " points; its own error, relative to the best-fit rigid body):\n"
                << "  before:                                   " << format_number(before.value_m * 1e6, 4) << " um\n"
                << "  after, volumetric tables (iso230_*.csv):  " << format_number(after.value_m * 1e6, 4) << " um ("
                << format_number(after.value_m / before.value_m, 3) << " of before: "
                << (pass ? "at most a third" : "NOT below a third") << ")\n"
                << "  after, LinuxCNC per-joint tables only:    " << format_number(after_joints.value_m * 1e6, 4)
                << " um\n"
                << "  after, per-joint + straightness.csv:      " << format_number(after_cross.value_m * 1e6, 4) << " um\n";
    }
  }
  if (a.json) {
    std::cout << j.dump() << "\n";
    return;
  }
  for (const auto& f : written) std::cout << "wrote " << f << "\n";
}

void add_compensate_map_commands(CLI::App& app, CliContext& ctx) {
  add_commands(*shared_subcommand(app, "compensate", "Compensation tables from identified machine errors (docs/compensation.md)"),
               ctx,
               {command("map",
                        "the error map's tables: ISO 230-1 volumetric tables, LinuxCNC per-joint tables, the cross-axis "
                        "table; --verify on the virtual machine",
                        &run)});
}

const CommandGroup group(&add_compensate_map_commands);

}  // namespace

}  // namespace guideway::cli
