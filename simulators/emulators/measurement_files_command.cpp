// `guideway-emulate workpiece` and `guideway-emulate artifact`: measurement files from the virtual
// machine tool for `guideway identify flatness` and `guideway identify artifact` (files only, no
// transport). Prints the paths written.
#include <iostream>
#include <memory>
#include <optional>

#include "simulators/emulators/emulator_command.hpp"
#include "simulators/emulators/measurement_files.hpp"

namespace guideway::simulators::emulators {
namespace {

machine::Machine machine_from(const std::string& file) {
  return machine::Machine(file.empty() ? machine::default_machine_config() : machine::load_machine_config(file));
}

template <class F>
int report_errors(const char* name, F&& f) {
  try {
    f();
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "guideway-emulate " << name << ": " << e.what() << "\n";
    return 1;
  }
}

void add_workpiece(CLI::App& app, int& exit_code) {
  struct Args {
    std::string machine, out_dir;
    std::vector<double> feeds{2.0, 8.0};
    double rpm = 110, traverse_mm = 600, x_start_mm = 0, profile_step_mm = 0.05, step_mm = 10;
    double probe_radius_mm = 500;
    std::optional<double> parallelism_um;
    std::uint64_t seed = 0;
    std::size_t passes = 1;
  };
  auto a = std::make_shared<Args>();
  auto* sub = app.add_subcommand(
      "workpiece", "files of Mu's experiment: faced-workpiece profiles, the X traverse, a run-out revolution");
  sub->add_option("--out-dir", a->out_dir, "directory for the files")->required();
  sub->add_option("--machine", a->machine, "virtual machine tool file (default: config/machine-example.toml)");
  sub->add_option("--feed-mm-per-min", a->feeds, "facing feed(s); one profile per feed")->capture_default_str();
  sub->add_option("--rpm", a->rpm, "spindle speed")->capture_default_str();
  sub->add_option("--traverse-mm", a->traverse_mm, "X travel of the cut and of the traverse")->capture_default_str();
  sub->add_option("--x-start-mm", a->x_start_mm, "X at the start")->capture_default_str();
  sub->add_option("--profile-step-mm", a->profile_step_mm, "profilometer point spacing")->capture_default_str();
  sub->add_option("--step-mm", a->step_mm, "autocollimator foot spacing")->capture_default_str();
  sub->add_option("--passes", a->passes,
                  "traverse passes forward and back, 1 s a station, 10 s between passes (> 1: the file gets t_s and "
                  "pass columns, for guideway explain --model traverse)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  sub->add_option("--probe-radius-mm", a->probe_radius_mm, "run-out probe radius (plate diameter / 2)")
      ->capture_default_str();
  sub->add_option("--parallelism-um", a->parallelism_um,
                  "plate-to-carriage parallelism p written for Eq. 21 (default: the machine's "
                  "plate_parallelism_urad times the plate diameter)");
  sub->add_option("--seed", a->seed, "noise seed (0: the machine's)")->capture_default_str();
  sub->callback([a, &exit_code] {
    exit_code = report_errors("workpiece", [&] {
      WorkpieceFilesSpec s;
      s.x_start_m = a->x_start_mm * 1e-3;
      s.traverse_m = a->traverse_mm * 1e-3;
      s.spindle_rpm = a->rpm;
      s.profile_step_m = a->profile_step_mm * 1e-3;
      s.step_m = a->step_mm * 1e-3;
      s.passes = a->passes;
      s.probe_radius_m = a->probe_radius_mm * 1e-3;
      if (a->parallelism_um) s.parallelism_m = *a->parallelism_um * 1e-6;
      s.seed = a->seed;
      for (const auto& p : write_workpiece_files(machine_from(a->machine), s, a->feeds, a->out_dir))
        std::cout << p << "\n";
    });
  });
}

void add_artifact(CLI::App& app, int& exit_code) {
  struct Args {
    std::string machine, out_dir, axis = "x";
    std::vector<double> other_mm;
    double start_mm = 50, pitch_mm = 50, spot_noise_px = 0.1, laser_noise_um = 0.05;
    std::size_t targets = 9;
    std::uint64_t seed = 0, artifact_seed = 2019;
  };
  auto a = std::make_shared<Args>();
  auto* sub = app.add_subcommand("artifact", "files of Wei's 1-D artifact: calibration, horizontal, vertical");
  sub->add_option("--out-dir", a->out_dir, "directory for the files")->required();
  sub->add_option("--machine", a->machine, "virtual machine tool file (default: config/machine-example.toml)");
  sub->add_option("--axis", a->axis, "the axis the artifact lies along")
      ->check(CLI::IsMember({"x", "y", "z"}))
      ->capture_default_str();
  sub->add_option("--other-mm", a->other_mm, "where it lies: the positions of the other axes, X Y Z (default 0 0 0)")
      ->expected(3);
  sub->add_option("--start-mm", a->start_mm, "position of the first target along the axis")->capture_default_str();
  sub->add_option("--pitch-mm", a->pitch_mm, "target spacing")->capture_default_str();
  sub->add_option("--targets", a->targets, "number of targets")->capture_default_str();
  sub->add_option("--spot-noise-px", a->spot_noise_px, "white noise of every spot coordinate")->capture_default_str();
  sub->add_option("--laser-noise-um", a->laser_noise_um, "noise of the calibration's laser positions")
      ->capture_default_str();
  sub->add_option("--seed", a->seed, "measurement noise seed (0: the machine's)")->capture_default_str();
  sub->add_option("--artifact-seed", a->artifact_seed, "seed of the artifact's own imperfections")
      ->capture_default_str();
  sub->callback([a, &exit_code] {
    exit_code = report_errors("artifact", [&] {
      ArtifactFilesSpec s;
      s.axis = a->axis == "y" ? machine::Axis::y : a->axis == "z" ? machine::Axis::z : machine::Axis::x;
      if (a->other_mm.size() == 3) s.other = {a->other_mm[0] * 1e-3, a->other_mm[1] * 1e-3, a->other_mm[2] * 1e-3};
      s.start_m = a->start_mm * 1e-3;
      s.pitch_m = a->pitch_mm * 1e-3;
      s.targets = a->targets;
      s.spot_noise_px = a->spot_noise_px;
      s.laser_noise_m = a->laser_noise_um * 1e-6;
      s.seed = a->seed;
      s.artifact_seed = a->artifact_seed;
      for (const auto& p : write_artifact_files(machine_from(a->machine), s, a->out_dir)) std::cout << p << "\n";
    });
  });
}

const EmulatorCommand workpiece_registered{add_workpiece};
const EmulatorCommand artifact_registered{add_artifact};

}  // namespace
}  // namespace guideway::simulators::emulators
