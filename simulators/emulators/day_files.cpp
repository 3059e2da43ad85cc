// A day's tests of the error map from the virtual machine tool (day_files.hpp): three-plane ballbar, traverses, their
// files.
#include "simulators/emulators/day_files.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "core/number_format.hpp"
#include "core/units.hpp"
#include "formats/dbb_run.hpp"
#include "models/flatness/angles.hpp"
#include "simulators/emulators/measurement_files.hpp"
#include "simulators/machine/dbb_runs.hpp"

namespace guideway::simulators::emulators {

namespace {

namespace fs = std::filesystem;

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out.flush()) throw std::runtime_error(path.string() + ": cannot write");
}

std::uint64_t seed_of(const machine::Machine& m, std::uint64_t seed) { return seed != 0 ? seed : m.config().noise.seed; }

machine::Vec3 middle(const DayPlan& p) {
  machine::Vec3 c{};
  for (std::size_t j = 0; j < 3; ++j) c[j] = 0.5 * (p.travel_m[j][0] + p.travel_m[j][1]);
  return c;
}

// The autocollimator traverse of one carriage, as the straightness session writes it for that axis: stations
// at the carriage's positions, slopes with the axis' signs (models/flatness/angles.hpp), time and pass.
std::string traverse_csv(const machine::Machine& m, const DayPlan& p, int j, std::uint64_t seed) {
  machine::TraverseSpec t;
  t.axis = static_cast<machine::Axis>(j);
  t.start_m = p.travel_m[static_cast<std::size_t>(j)][0];
  t.end_m = p.travel_m[static_cast<std::size_t>(j)][1];
  t.step_m = p.traverse_step_m;
  t.other = middle(p);
  t.dwell_s = 2.0;
  t.seed = seed;
  std::ostringstream out;
  out << "# step_mm = " << shortest(p.traverse_step_m * 1e3) << "\n# axis = " << "xyz"[j]
      << "\n# machine = " << m.config().name << "\n# source = guideway simulate day (autocollimator traverse)\n"
      << "x_mm,pitch_arcsec,yaw_arcsec,t_s,pass\n";
  const auto passes = m.autocollimator_passes(t, p.traverse_passes, 2.0);
  for (std::size_t k = 0; k < passes.size(); ++k)
    for (const auto& s : passes[k])
      out << shortest(s.position_m * 1e3) << ","
          << shortest(models::flatness::traverse_pitch_sign(j) * s.pitch_rad / rad_per_arcsec) << ","
          << shortest(models::flatness::traverse_yaw_sign(j) * s.yaw_rad / rad_per_arcsec) << "," << shortest(s.t_s)
          << "," << k + 1 << "\n";
  return out.str();
}

}  // namespace

std::vector<DayTest> write_day_files(const machine::Machine& machine, const DayPlan& plan, const std::string& dir) {
  const fs::path root(dir);
  const std::uint64_t seed = seed_of(machine, plan.seed);
  const machine::Vec3 mid = middle(plan);
  std::vector<DayTest> tests;
  nlohmann::json manifest;
  manifest["format"] = "guideway/map-day/1";
  manifest["machine"] = machine.config().name;
  const auto& tool = machine.config().tool_offset;
  manifest["tool_offset_mm"] = {tool[0] * 1e3, tool[1] * 1e3, tool[2] * 1e3};
  for (std::size_t j = 0; j < 3; ++j)
    manifest["travel_mm"][std::string(1, "xyz"[j])] = {plan.travel_m[j][0] * 1e3, plan.travel_m[j][1] * 1e3};
  manifest["tests"] = nlohmann::json::array();

  // The ballbar: CCW and CW in each plane, about the volume's centre; a vertical plane's 220 deg arc.
  double t0 = 0.0;
  for (const auto& plane : plan.planes) {
    machine::DbbCircleSpec spec;
    spec.plane = plane == "xz" ? machine::Plane::xz : plane == "yz" ? machine::Plane::yz : machine::Plane::xy;
    const int a = plane == "yz" ? 1 : 0, b = plane == "xy" ? 1 : 2, n = 3 - a - b;
    for (int ax : {a, b}) {
      const auto& tr = plan.travel_m[static_cast<std::size_t>(ax)];
      if (mid[static_cast<std::size_t>(ax)] - plan.ballbar_radius_m < tr[0] - 1e-9 ||
          mid[static_cast<std::size_t>(ax)] + plan.ballbar_radius_m > tr[1] + 1e-9)
        throw std::invalid_argument("day: the ballbar circle of radius " + shortest(plan.ballbar_radius_m * 1e3) +
                                    " mm in " + plane + " does not fit the travel of " + std::string(1, "XYZ"[ax]));
    }
    spec.radius_m = plan.ballbar_radius_m;
    spec.feed_m_per_s = plan.ballbar_feed_mm_per_min * 1e-3 / 60.0;
    spec.center = mid;
    if (plane != "xy") {
      spec.start_angle_rad = -20.0 * std::numbers::pi / 180.0;
      spec.data_arc_rad = 220.0 * std::numbers::pi / 180.0;
    }
    DayTest test{"dbb", plane, {}};
    for (const auto direction : {formats::DbbDirection::ccw, formats::DbbDirection::cw}) {
      machine::DbbCircleSpec s = spec;
      s.direction = direction;
      if (direction == formats::DbbDirection::cw && plane != "xy") s.start_angle_rad += s.data_arc_rad;
      s.t0_s = t0;
      s.seed = seed + 100 + tests.size() * 2 + (direction == formats::DbbDirection::cw ? 1 : 0);
      const std::string name = "dbb_" + plane + (direction == formats::DbbDirection::ccw ? "_ccw.csv" : "_cw.csv");
      formats::DbbRun run = machine::simulate_dbb_run(machine, s, name, machine::AngleSource::encoders);
      run.metadata["center_n_mm"] = shortest(mid[static_cast<std::size_t>(n)] * 1e3);
      run.metadata["overshoot_deg"] = "45";
      run.metadata["source"] = "guideway simulate day (ballbar, " + plane + ")";
      formats::write_dbb_run(run, (root / name).string());
      test.files.push_back(name);
      t0 += run.t_s.empty() ? 0.0 : run.t_s.back() + 60.0;
    }
    manifest["tests"].push_back({{"kind", "dbb"}, {"plane", plane}, {"files", test.files}});
    tests.push_back(test);
  }
  for (int j = 0; j < 3; ++j) {
    if (!plan.traverse[static_cast<std::size_t>(j)]) continue;
    const std::string name = std::string("traverse_") + "xyz"[j] + ".csv";
    write_text(root / name, traverse_csv(machine, plan, j, seed + 200 + static_cast<std::uint64_t>(j)));
    manifest["tests"].push_back({{"kind", "straightness"}, {"axis", std::string(1, "xyz"[j])}, {"files", {name}}});
    tests.push_back({"straightness", std::string(1, "xyz"[j]), {name}});
  }
  for (int j = 0; j < 3; ++j) {
    if (!plan.artifact[static_cast<std::size_t>(j)]) continue;
    const auto J = static_cast<std::size_t>(j);
    const std::string sub = std::string("artifact_") + "xyz"[j];
    fs::create_directories(root / sub);
    ArtifactFilesSpec a;
    a.axis = static_cast<machine::Axis>(j);
    a.targets = plan.artifact_targets;
    a.start_m = plan.travel_m[J][0];
    a.pitch_m = (plan.travel_m[J][1] - plan.travel_m[J][0]) / static_cast<double>(plan.artifact_targets - 1);
    a.other = mid;
    a.seed = seed + 300 + J;
    a.artifact_seed = 2019 + J;
    write_artifact_files(machine, a, (root / sub).string());
    const std::vector<std::string> files{sub + "/calibration.csv", sub + "/horizontal.csv", sub + "/vertical.csv"};
    manifest["tests"].push_back({{"kind", "artifact"},
                                 {"axis", std::string(1, "xyz"[j])},
                                 {"other_mm", {mid[0] * 1e3, mid[1] * 1e3, mid[2] * 1e3}},
                                 {"files", files}});
    tests.push_back({"artifact", std::string(1, "xyz"[j]), files});
  }
  if (plan.runout) {
    WorkpieceFilesSpec w;
    w.traverse_m = plan.travel_m[0][1] - plan.travel_m[0][0];
    w.seed = seed + 400;
    write_text(root / "runout.csv", runout_revolution_csv(machine, w));
    manifest["tests"].push_back({{"kind", "runout"}, {"files", {"runout.csv"}}});
    tests.push_back({"runout", "", {"runout.csv"}});
  }
  write_text(root / "day.json", manifest.dump(2) + "\n");
  return tests;
}

}  // namespace guideway::simulators::emulators
