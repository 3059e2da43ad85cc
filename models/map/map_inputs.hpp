#pragma once
// What the map is fitted to: the results of a day's tests, each in the terms the map's observation model
// reads (machine directions, SI): the 1-D artifact on an axis (models/artifact: its six error motions per
// target), the autocollimator traverse of an axis (the carriage's pitch and yaw per station, per pass, with
// time), the ballbar's runs in a plane (the raw bar readings: the map fits them itself, through its chain),
// and the run-out plate's squareness (a cross-check only). Pure functions (file reading aside); thread safe.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "formats/dbb_run.hpp"
#include "models/artifact/artifact.hpp"
#include "models/map/error_map.hpp"

namespace guideway::models::map {

// The artifact on one axis: per target, relative to target 0, the tool's displacement and the carriage's
// rotation in machine directions (index 0..2 = x, y, z), with their standard uncertainties.
struct ArtifactTest {
  std::string source;
  int axis = 0;
  Vec3 other_m{};  // the positions of the other axes while it was measured (where the artifact lay)
  std::vector<double> position_m;
  std::vector<Vec3> displacement_m, u_displacement_m;
  std::vector<Vec3> rotation_rad, u_rotation_rad;
  std::vector<double> roll_again_rad, u_roll_again_rad;  // the roll read again in the second placement
};
// The identification of the artifact (its result's axis) as a test of the map; `other_m`: where it lay.
ArtifactTest artifact_test(const artifact::ArtifactResult& result, const Vec3& other_m, const std::string& source);

// The autocollimator traverse of a carriage. The file (docs/formats.md "Straightness traverse") holds
// slopes along the traversed axis; here they are the carriage's rotations about the axis' pitch and yaw
// axes (docs/conventions.md "Autocollimator traverse of any axis").
struct TraverseTest {
  std::string source;
  int axis = 0;
  std::vector<double> position_m;  // of the carriage
  std::vector<double> pitch_rad;   // rotation about pitch_component(axis) - 3
  std::vector<double> yaw_rad;     // about yaw_component(axis) - 3; empty: the file had none
  std::vector<double> t_s;         // empty: no times
  std::vector<int> pass;           // 1, 2, ... (all 1 without the column)
  double u_angle_rad = 0.0;        // per reading (the instrument's)
};
// The sign that turns a traverse file's pitch (yaw) slope of `axis` into the carriage's rotation about its
// pitch (yaw) axis: X -1 (+1), Y +1 (-1), Z +1 (-1).
[[nodiscard]] double pitch_rotation_sign(int axis);
[[nodiscard]] double yaw_rotation_sign(int axis);
// A traverse file. `# axis = x|y|z` says which carriage ran and that x_mm is its position; without it the
// file is a reflector on feet along X (x_mm its rear foot, the carriage midway, step_mm on). `axis`
// overrides the file's. Throws CsvError "file:line: message".
TraverseTest parse_traverse_test(std::string_view text, const std::string& source, std::optional<int> axis = {},
                                 double u_angle_rad = 0.0);
TraverseTest read_traverse_test(const std::string& path, std::optional<int> axis = {}, double u_angle_rad = 0.0);

// The run-out plate's squareness of the spindle to X (Mu's Eq. 21): a cross-check of the ballbar's XZ
// squareness (the spindle axis and the Z travel need not be parallel: the check says so when they differ).
struct RunoutCheck {
  std::string source;
  double squareness_rad = 0.0;  // theta_0 (a magnitude: the run-out's once-per-revolution peak to peak)
  double u_rad = 0.0;
};

// The day's tests.
struct MapInputs {
  std::string machine;
  Vec3 tool_offset_m{};
  std::optional<std::array<Travel, 3>> travel;  // unset: what the tests along each axis covered
  std::vector<ArtifactTest> artifacts;
  std::vector<TraverseTest> traverses;
  std::vector<formats::DbbRun> ballbar_runs;  // any planes; center_a_mm / center_b_mm (and center_n_mm) place them
  std::vector<RunoutCheck> runouts;
};

// Parses an axis name ("x", "y", "z", either case); nullopt otherwise.
[[nodiscard]] std::optional<int> parse_axis(std::string_view name);

// The circle's centre along the plane's normal (metadata `center_n_mm`, 0 when absent), and the plane's
// axes (a, b, n).
[[nodiscard]] double run_center_n_m(const formats::DbbRun& run);
[[nodiscard]] std::array<int, 3> plane_axes(const std::string& plane);

}  // namespace guideway::models::map
