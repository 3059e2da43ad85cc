#pragma once
// The error map's tests (tests/models/map/CMakeLists.txt): the second machine a test builds (every one of the 21 errors
// non-zero, a tool offset, other values than the example's), a simulated day on a machine and its fit, the
// truth of each function on the map's travel.
#include <array>
#include <cmath>
#include <filesystem>
#include <string>

#include "models/map/day.hpp"
#include "models/map/fit.hpp"
#include "simulators/emulators/day_files.hpp"
#include "simulators/machine/map_truth.hpp"

namespace guideway::map_test {

namespace mm = guideway::models::map;
namespace sm = guideway::simulators::machine;

// A second machine: all 21 errors with values of their own (polynomials in mm, um and urad), a tool 120 mm
// below the spindle nose and off its axis, other backlash, lag and instrument errors.
inline constexpr const char* second_machine_toml = R"(# The error map's second machine (tests/models/map/map_test_support.hpp): every one of the 21 errors non-zero.
[machine]
name = "second-vmc"
tool_offset_mm = [25, -15, -120]

[noise]
seed = 7
autocollimator_arcsec = 0.05
micrometer_um = 0.01

[squareness]
xy_urad = -40
xz_urad = 35
yz_urad = 15

[dbb]
center_offset_x_um = -1.5
center_offset_y_um = 2.0
noise_um = 0.1

[spindle]
tilt_x_urad = 30
plate_parallelism_urad = 2

[autocollimator]
pitch_drift_arcsec_per_min = 0.05
rocking_arcsec = 0.1

[axis.x]
scale_ppm = 12
e_x_um = [0, 0, 3e-5]
e_y_um = [0, 0.01, -1.5e-4, 2e-6]
e_z_um = [0, 0, 2e-4, -1e-6]
e_a_urad = [3, 0.02]
e_b_urad = [0, 0.04, -1e-4]
e_c_urad = [0, -0.03, 5e-5]
servo_lag_ms = 25
backlash_um = 1.5
encoder_resolution_um = 0.1

[axis.y]
scale_ppm = -8
e_x_um = [0, 0, 1.2e-4, -1e-6]
e_y_um = [0, 0, -2e-5]
e_z_um = [0, -0.005, -1e-4, 1.5e-6]
e_a_urad = [0, 0.03, 4e-5]
e_b_urad = [10, -0.02, 1e-4]
e_c_urad = [0, 0.025, -6e-5]
servo_lag_ms = 25
backlash_um = 1.0
encoder_resolution_um = 0.1

[axis.z]
scale_ppm = 20
e_x_um = [0, 0, 1e-4]
e_y_um = [0, 0, -8e-5, 1e-6]
e_z_um = [0, 0, 4e-5]
e_a_urad = [0, -0.04]
e_b_urad = [0, 0.05, 1e-4]
e_c_urad = [0, 0.03, -5e-5]
servo_lag_ms = 25
backlash_um = 1.5
encoder_resolution_um = 0.1
)";

// Writes the second machine's file into `dir` and returns its path.
inline std::string write_second_machine(const std::string& dir) {
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/second-machine.toml";
  FILE* f = std::fopen(path.c_str(), "w");
  std::fputs(second_machine_toml, f);
  std::fclose(f);
  return path;
}

inline std::array<mm::Travel, 3> travel_of(const simulators::emulators::DayPlan& p) {
  std::array<mm::Travel, 3> t{};
  for (std::size_t j = 0; j < 3; ++j) t[j] = {p.travel_m[j][0], p.travel_m[j][1]};
  return t;
}

// A day of `plan` on the machine, written to `dir` and read back through its manifest, as `guideway map fit --day`.
inline mm::MapInputs simulated_day(const sm::Machine& m, const simulators::emulators::DayPlan& plan,
                                   const std::string& dir) {
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  simulators::emulators::write_day_files(m, plan, dir);
  return mm::day_inputs(mm::read_day(dir + "/day.json"));
}

// A function against the machine: RMS over the travel of (found - truth) and of its u.
struct Against {
  double truth_rms = 0, found_rms = 0, diff_rms = 0, u_rms = 0;
  [[nodiscard]] double ratio() const { return diff_rms / u_rms; }
};
inline Against against_truth(const mm::ErrorMap& map, const sm::MachineConfig& m, int j, int c) {
  Against a;
  const auto& t = map.travel[static_cast<std::size_t>(j)];
  const int n = 101;
  for (int i = 0; i < n; ++i) {
    const double u = t.lo_m + t.length_m() * i / (n - 1);
    const double truth = sm::truth_value(m, map.travel, j, c, u), found = map.value(j, c, u),
                 uu = map.uncertainty(j, c, u);
    a.truth_rms += truth * truth / n;
    a.found_rms += found * found / n;
    a.diff_rms += (found - truth) * (found - truth) / n;
    a.u_rms += uu * uu / n;
  }
  a.truth_rms = std::sqrt(a.truth_rms);
  a.found_rms = std::sqrt(a.found_rms);
  a.diff_rms = std::sqrt(a.diff_rms);
  a.u_rms = std::sqrt(a.u_rms);
  return a;
}

}  // namespace guideway::map_test
