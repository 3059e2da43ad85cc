#pragma once
// Six error motions of a linear axis from a 1-D artifact (Wei et al. 2019, Sec. 3): targets of a
// plane mirror and a paraboloid, read by an angle sensor carried by the machine. Each placement
// (calibration on a reference, the machine with the artifact horizontal, then vertical) gives per
// target the relative mirror angles theta_x, theta_y and the relative feature-point positions
// X_F, Y_F (Sec. 3.2's equations); the differences machine - calibration give, per target and
// relative to the first target, roll and pitch (horizontal), yaw (vertical), and the positioning
// and straightness errors after the angle-coupling correction k m epsilon. Pure functions (file
// reading aside); thread safe. SI inside (m, rad); docs/formats.md "1-D artifact" has the files.

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace guideway::models::artifact {

enum class ArtifactPlacement { calibration, horizontal, vertical };

// One artifact file: per target, the machine (or laser) coordinates of the measurement point and
// the four spot coordinates (px). Conversion coefficients only from the calibration file.
struct ArtifactReadings {
  std::string source;
  ArtifactPlacement placement = ArtifactPlacement::calibration;
  int axis = 0;  // the machine axis the artifact lies along (`# axis = x|y|z`, default x): 0, 1, 2
  double k_m_per_px = 0.0;    // calibration only (0 = not given: a scan must give it)
  double m_px_per_rad = 0.0;  // calibration only (0 = not given)
  double u_k_m_per_px = 0.0;
  double u_m_px_per_rad = 0.0;
  double u_spot_px = 0.0;     // standard uncertainty of each spot coordinate
  double u_position_m = 0.0;  // of each measurement-point coordinate (laser or machine feedback)
  std::vector<int> target;
  std::vector<double> along_m;   // X_M (the axis' own column: X_M_mm, Y_M_mm or Z_M_mm)
  std::vector<double> across_m;  // the placement's across column (across_axis): Y_M (X horizontal), Z_M (X vertical)
  std::vector<double> x_M_px, y_M_px, x_F_px, y_F_px;
  std::vector<std::size_t> line;
};

// The machine axis a placement reads across an artifact along `axis`: horizontal X -> y, Y -> x, Z -> x;
// vertical X -> z, Y -> z, Z -> y (for Z both placements stand upright, turned 90 deg apart about z); the
// calibration reads across as the horizontal placement does.
[[nodiscard]] int across_axis(int axis, ArtifactPlacement placement);

// Throws CsvError "file:line: message": missing placement or column, non-numeric cells, a placement
// other than `expected`, an axis other than x, y, z, targets not numbered 0, 1, 2, ... in order, fewer than 2
// targets.
ArtifactReadings parse_artifact_readings(std::string_view text, const std::string& source, ArtifactPlacement expected);
ArtifactReadings read_artifact_readings(const std::string& path, ArtifactPlacement expected);

// Sec. 3.1-3.2 for one placement, relative to target 0: theta_x = (y_F,i - y_F,0)/m,
// theta_y = (x_F,i - x_F,0)/m, X_F = k (x_M0 - x_F0) + (X_Mi - X_M0) + k (x_Fi - x_Mi), likewise Y_F.
struct ArtifactPlacementValues {
  std::vector<double> theta_x_rad, theta_y_rad, X_F_m, Y_F_m;
};
ArtifactPlacementValues placement_values(const ArtifactReadings& r, double k_m_per_px, double m_px_per_rad);

// The error motions of the tool (sensor) relative to the table at one target, relative to target 0,
// in ISO 230-1 signs (the virtual machine tool's): dx positioning, dy / dz straightness, ex roll,
// ey pitch, ez yaw (right-handed about +x, +y, +z). Wei's delta = X'_F - X_F - k m epsilon is the
// apparent shift of the targets, the opposite of the tool's error: d = -delta.
// For an artifact along another axis the same quantities are taken in the artifact's own terms: d_x along it,
// d_y and e_y across and about across in the horizontal placement (across_axis), d_z and e_z in the vertical,
// e_x its roll; machine_errors() puts them in machine directions.
struct ArtifactTargetErrors {
  int target = 0;
  double x_m = 0.0;  // machine position of the measurement point along the axis (horizontal placement)
  double dx_m = 0, dy_m = 0, dz_m = 0, ex_rad = 0, ey_rad = 0, ez_rad = 0;
  double u_dx_m = 0, u_dy_m = 0, u_dz_m = 0, u_ex_rad = 0, u_ey_rad = 0, u_ez_rad = 0;
  double ex_vertical_rad = 0, u_ex_vertical_rad = 0;  // roll again from the vertical placement (a check)
};

// Wei Sec. 3.2: k and m calibrated on the reference by moving the sensor across one paraboloid by
// laser-measured distances (`# scan = displacement`, columns X_M_mm,x_M_px: x_M = c + X_M / k) and by
// tilting a mirror by known angles (`# scan = angle`, columns theta_arcsec,x_F_px: x_F = c + m theta).
// A straight-line least-squares fit of the spot against the reference; u from s^2 (J^T J)^-1.
struct ConversionFit {
  std::string source;
  double coefficient = 0.0;  // k (m/px) or m (px/rad)
  double u = 0.0;
  double slope = 0.0;  // spot per reference unit (px/m or px/rad)
  double u_slope = 0.0;
  double intercept_px = 0.0;
  double residual_rms_px = 0.0;
  std::size_t points = 0;
};
// Throw CsvError "file:line: message" (missing column, non-numeric cell, wrong `scan`, < 3 points,
// no spread in the reference).
ConversionFit fit_k_scan(std::string_view text, const std::string& source);
ConversionFit fit_m_scan(std::string_view text, const std::string& source);
ConversionFit read_k_scan(const std::string& path);
ConversionFit read_m_scan(const std::string& path);

struct ArtifactOptions {
  bool angle_coupling = true;           // apply Wei's k m epsilon correction (off only to show its size)
  std::optional<ConversionFit> k_scan;  // when given, k and u(k) come from it instead of the metadata
  std::optional<ConversionFit> m_scan;
};

struct ArtifactResult {
  int axis = 0;  // the files' axis
  double k_m_per_px = 0, m_px_per_rad = 0, u_k_m_per_px = 0, u_m_px_per_rad = 0;
  std::optional<ConversionFit> k_scan, m_scan;  // the fits used, when scans were given
  double coupling_m_per_rad = 0;                // k m
  ArtifactPlacementValues calibration, horizontal, vertical;
  std::vector<ArtifactTargetErrors> targets;
};

// One target's error motions in machine directions (index 0, 1, 2 = x, y, z): displacement, rotation and
// their standard uncertainties (for X the same numbers as dx..ez).
struct MachineErrors {
  std::array<double, 3> d{}, u_d{}, r{}, u_r{};
};
[[nodiscard]] MachineErrors machine_errors(const ArtifactTargetErrors& e, int axis);

// Throws CsvError naming a file when the three do not have the same targets or axis, or when k or m is
// neither in the calibration's metadata nor given by a scan.
ArtifactResult identify_artifact(const ArtifactReadings& calibration, const ArtifactReadings& horizontal,
                                 const ArtifactReadings& vertical, const ArtifactOptions& options = {});

}  // namespace guideway::models::artifact
