#pragma once
// Straightness from an autocollimator traverse (docs/formats.md, "Straightness traverse") or a slope
// profile (a DABAM entry, "DABAM slope profile"): the reflector, on feet `step` apart, is moved one step at
// a time; each reading is the slope angle of the chord between its two feet. Heights: h_0 = 0,
// h_{k+1} = h_k + s_k * tan(theta_k) (theta > 0: the surface rises towards +x), s_k the reading's own
// spacing (the step, or the measured spacing of positions that jitter within 5 % of it). Evaluated per
// ISO 230-1 against the end-point line, the least-squares line and the minimum zone (exact, from the
// convex hull, O(n log n)), fitted with the polynomial of
// Mu 2012 Eqs. 10-12 (order by BIC), with uncertainties from the random walk of the angle noise.
// Pure functions; thread safe. SI units inside (m, rad).

#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/csv_table.hpp"
#include "models/flatness/angles.hpp"

namespace guideway::models::flatness {

// A traverse as read from a file (SI). Reading k rests on x_m[k] (rear foot) and the next reading's rear
// foot (x_m[k] + step_m for the last).
struct AngleTraverse {
  std::string source;
  double step_m = 0.0;
  std::vector<double> x_m;
  std::vector<double> pitch_rad;  // vertical plane: slope angle, > 0 rising towards +x
  std::vector<double> yaw_rad;    // horizontal plane (optional): > 0 turning towards +y
  std::vector<std::size_t> line;  // file line of each reading
  Autocollimator instrument;      // what read it (its range checked on the readings)
  // The largest departure of a reading's spacing from the step, as a fraction of it (0: on the grid).
  double jitter = 0.0;
};

// Validates and converts: `# step_mm`, columns x_mm,pitch_arcsec[,yaw_arcsec], stations one step apart
// within station_jitter_tolerance (a gap = "missing station"), angles finite and their span inside the
// instrument's range about their middle. Throws CsvError "file:line: message".
AngleTraverse parse_angle_traverse(std::string_view text, const std::string& source, const Autocollimator& ac = {});
// A traverse file, or a DABAM entry (a path ending in .dat or .txt: slope_profile_traverse of it).
AngleTraverse read_angle_traverse(const std::string& path, const Autocollimator& ac = {});
// A slope profile (a slope at each position, e.g. a DABAM entry) as a traverse: the step is the median
// spacing, each position the mirror midway between the feet (the rear foot half a step before it), each
// reading's own spacing used as measured within station_jitter_tolerance of the step (beyond: refused at
// its line), the angle atan(slope). Throws CsvError.
AngleTraverse slope_profile_traverse(const std::string& source, const std::vector<double>& x_m,
                                     const std::vector<double>& slope_rad, const std::vector<std::size_t>& lines,
                                     const Autocollimator& ac);
// The instrument a file is read with by default: the deflectometer for a DABAM entry (the database's
// instruments), the autocollimator otherwise.
Autocollimator default_instrument(const std::string& path);

// The traverse format's quantities, each within its plausible bound (docs/formats.md, "Straightness
// traverse"), as `guideway identify straightness` and `explain --model traverse` read them; a value
// outside is a CsvError naming file:line and the bound. The bounds are the straightness session's
// options' (a step of 0.1 mm to 10 m, a station within 100 m, at most 100000 readings a pass).
inline constexpr double traverse_min_step_mm = 0.1;
inline constexpr double traverse_max_step_mm = 10000.0;
inline constexpr double traverse_max_abs_x_mm = 2e5;
inline constexpr std::size_t traverse_max_readings = 100000;
inline constexpr double traverse_max_abs_t_s = 1e7;  // 116 days on the file's clock
inline constexpr double traverse_max_pass = 1e6;
double traverse_step_mm(const CsvTable& t);
double traverse_x_mm(const CsvTable& t, const CsvTable::Row& row, std::size_t col);
// An angle within a slope's plausible bound (max_abs_angle_rad); the instrument's range is checked on the
// span of a file's readings (check_instrument_range).
double traverse_angle_rad(const CsvTable& t, const CsvTable::Row& row, std::size_t col);
double traverse_time_s(const CsvTable& t, const CsvTable::Row& row, std::size_t col);
double traverse_pass(const CsvTable& t, const CsvTable::Row& row, std::size_t col);  // a whole number >= 1

// Deviations from one reference line, with the straightness (max - min) and its standard uncertainty.
struct ReferenceLine {
  double slope = 0.0;                 // of the line (dimensionless)
  double intercept_m = 0.0;           // line value at the first station
  std::vector<double> deviation_m;    // height - line, per station
  std::vector<double> u_deviation_m;  // standard uncertainty of each deviation
  double straightness_m = 0.0;        // max - min of deviation_m
  // Standard uncertainty: the first-order (random-walk) propagation combined with the selection bias
  // of a max - min statistic, u = sqrt(u_first_order^2 + selection_bias^2).
  double u_straightness_m = 0.0;
  double u_first_order_m = 0.0;
  // Expected excess of the measured value over the true one because noise favours the extremes:
  // parametric bootstrap around the fitted polynomial (StraightnessOptions::bootstrap replicates); never
  // negative (max - min only grows with noise: a negative mean excess is the bootstrap's own scatter).
  double selection_bias_m = 0.0;
  // The same u with the readings' own scatter (StraightnessProfile::u_angle_data_rad) in place of the
  // instrument's u (NaN when the scatter is not known).
  double u_straightness_data_m = std::numeric_limits<double>::quiet_NaN();
  std::size_t max_index = 0;
  std::size_t min_index = 0;
};

// Mu Eq. 10 fitted through the chord slopes (Eq. 12), order by BIC; a value type.
struct PolynomialFit {
  int order = 0;                   // n of Eq. 10
  std::vector<double> b;           // b_0..b_n of Eq. 10 in m / m^k, x measured from the first station; b_0 = 0
  std::vector<double> u_b;         // standard uncertainties (from s^2 (J^T J)^-1 of the slope fit)
  std::vector<double> bic;         // BIC of orders 1..max tried (index order-1); order == bic.size(): the cap
  std::vector<double> residual_m;  // height - polynomial, per station
  double residual_rms_m = 0.0;
  double residual_max_m = 0.0;  // max |residual|
  double angle_residual_rms_rad = 0.0;
  double condition_number = 0.0;
  [[nodiscard]] double operator()(double x_from_start_m) const;
  [[nodiscard]] double slope(double x_from_start_m) const;  // Eq. 12: sum k b_k x^(k-1)
};

// One plane (vertical from pitch, horizontal from yaw).
struct StraightnessProfile {
  std::string plane;               // "vertical" | "horizontal"
  std::vector<double> x_m;         // stations (readings + 1)
  std::vector<double> height_m;    // integrated, h_0 = 0
  std::vector<double> u_height_m;  // random walk: u_theta * step * sqrt(k)
  double u_angle_rad = 0.0;        // per-reading standard uncertainty used (the instrument's)
  // The readings' own scatter (reading_scatter_rad: the finest wavelet details), NaN under 16 readings; when
  // it and u_angle_rad differ by more than u_disagreement_factor, `u_disagreement` says so.
  double u_angle_data_rad = std::numeric_limits<double>::quiet_NaN();
  std::string u_disagreement;
  double tilt_rad = 0.0;  // the readings' middle, (max + min) / 2: a mounting tilt
  double span_rad = 0.0;  // max - min of the readings
  ReferenceLine end_point;
  ReferenceLine least_squares;
  ReferenceLine minimum_zone;  // u: that of the least-squares evaluation at the zone's extreme stations
  PolynomialFit polynomial;
};

// Instrument and fit settings of an evaluation.
struct StraightnessOptions {
  Autocollimator instrument;
  int max_order = 8;    // highest polynomial order tried by the BIC selection
  int bootstrap = 200;  // replicates for the selection bias (0: none); fixed seed, reproducible
};

// Both planes of one traverse (horizontal only when the file has yaw readings).
struct StraightnessResult {
  std::string source;
  double step_m = 0.0;
  std::size_t readings = 0;
  Autocollimator instrument;  // the options' (its u_override) with the traverse's name and range
  double jitter = 0.0;        // AngleTraverse::jitter
  StraightnessProfile vertical;
  std::optional<StraightnessProfile> horizontal;
};

// One plane from equally spaced chord-slope angles. Throws std::invalid_argument on < 2 readings or
// a non-positive step.
StraightnessProfile straightness_from_angles(double x0_m, double step_m, const std::vector<double>& angle_rad,
                                             const StraightnessOptions& options = {},
                                             const std::string& plane = "vertical");
// The same with each reading's rear foot at x_m (the spacing of reading k is x_m[k+1] - x_m[k], the last
// one's step_m): positions that jitter are integrated as measured, the reference lines fitted in x.
StraightnessProfile straightness_from_stations(const std::vector<double>& x_m, double step_m,
                                               const std::vector<double>& angle_rad,
                                               const StraightnessOptions& options = {},
                                               const std::string& plane = "vertical");

StraightnessResult identify_straightness(const AngleTraverse& traverse, const StraightnessOptions& options = {});

// Minimum-zone straightness of points (x, y): the smallest vertical distance between two parallel
// lines enclosing all points (exact: one line carries an edge of the convex hull). Returns the zone
// width, the slope of the lines, and the intercept of the lower line at x = 0.
struct MinimumZone {
  double width = 0.0;
  double slope = 0.0;
  double lower_intercept = 0.0;
};
MinimumZone minimum_zone(const std::vector<double>& x, const std::vector<double>& y);

}  // namespace guideway::models::flatness
