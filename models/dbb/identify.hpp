#pragma once
// DBB identification: Lai, Liao and Chieng's third-order guideway model (multi-pattern weighted least
// squares, parameters named as in their Table 3) and the ballbar diagnostics a user expects
// (centre offset, scale, squareness, backlash, lateral play, reversal spikes, cyclic error, servo
// mismatch, straightness, ISO 230-4 circular deviation and hysteresis). Every fitted value comes with
// its standard uncertainty; parameters the given runs cannot separate are named and refused.
// Conventions: docs/conventions.md. Pure functions; thread safe.

#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "formats/dbb_run.hpp"
#include "models/common/lsq_combination.hpp"
#include "models/dbb/standard_figures.hpp"

namespace guideway::models::dbb {

// A reported quantity in boundary units (named in `name`, e.g. "_um", "_ppm").
struct Estimate {
  std::string name;
  double value = 0.0;
  double u = 0.0;  // standard uncertainty; NaN when not a fitted value
  bool fitted = true;
};

struct FitSummary {
  double rms_um = 0.0;
  std::size_t n = 0;
  double condition_number = 0.0;
  std::vector<std::string> unidentifiable;
  std::vector<std::string> why;  // on partial arcs or gappy runs: one per unidentifiable term, "name: why the
                                 // runs cannot separate it" (arcs.hpp)
  std::vector<LsqCombination> combinations;  // in the reported units
  std::string message;
};

struct RunSummary {
  std::string source;
  double radius_mm = 0.0;
  double height_mm = 0.0;
  std::string direction;
  double feed_mm_per_min = 0.0;
  std::size_t n = 0;
  double circular_deviation_um = 0.0;  // ISO 230-4 G, about the run's least-squares circle, over its data arc
  double data_arc_deg = 360.0;         // the arc its samples span (360: a full circle)
  std::size_t gaps = 0;                // dropouts inside it (formats::dbb_run_gaps)
  double residual_rms_um = 0.0;        // of the diagnostics fit
};

// A term fitted beside the model's own, so that it is not read as one of them: what EXPLAIN found on the
// same runs that the models do not hold (a drift, a vibration; models/compensation). Its coefficients are
// reported in Identification::beside, not among the diagnostics.
struct BesideTerm {
  std::string effect;                           // e.g. "thermal_drift"
  std::vector<std::string> names;               // one per column, unit last
  std::vector<std::vector<double>> columns_um;  // per column: um per unit, one value per sample of all the
                                                // runs in their order
  bool in_diagnostics = true;  // false: the diagnostics hold it themselves (a cyclic error): Lai's fit only
};

struct IdentifyOptions {
  // Known lead-screw periods; 0 = search the usual ball-screw leads.
  double cyclic_period_a_m = 0.0;
  double cyclic_period_b_m = 0.0;
  // Lai's model assumes the fixed ball stays put between patterns (one shared centre offset).
  bool lai_shared_center = true;
  // Standard uncertainty of the bar's calibrated length (um; 0: not stated). That length is in every
  // reading, so an error of it is the same offset in every dL: each parameter's u gains the fit's
  // response to that offset, |dp/dL0| u_L, in quadrature (docs/conventions.md "The bar's calibrated length").
  double bar_length_u_um = 0.0;
  std::vector<BesideTerm> beside;  // fitted beside both models' terms (throws when a column has the wrong size)
};

// One error's part of the circular deviation (the ranking a ballbar's software gives).
struct Contribution {
  std::string name;              // the diagnostic's name (e.g. "backlash_x_um")
  double contribution_um = 0.0;  // range of its fitted term about the least-squares circle over a run (as
                                 // G is the reading's), the largest over the runs
  double percent = 0.0;          // of the largest circular deviation G of those runs
};

struct Identification {
  std::string model = "lai3+ballbar";
  std::string plane = "xy";  // of the runs
  std::vector<RunSummary> runs;
  std::vector<Estimate> diagnostics;  // from the runs they model (h = 0): see notes
  std::vector<Contribution> ranking;  // the identified errors, largest part of G first: the diagnostics'
                                      // when the runs are a ballbar test they model, else Lai's terms
  std::string ranking_model;          // "diagnostics" or "lai3"
  std::vector<std::string> notes;     // what the diagnostics were fitted to and why
  std::vector<Estimate> lai3;         // only the identified parameters
  std::vector<Estimate> beside;       // the coefficients of IdentifyOptions::beside, from the fit the ranking comes
                                      // from (the diagnostics', else Lai's)
  FitSummary fit;                     // the Lai third-order fit
  FitSummary diagnostics_fit;
  StandardFigures standards;  // ISO 230-4 and ASME B5.54 figures with their test conditions
};

// ISO 230-4's circular deviation of one run's reading (um) at its commanded angles: the range of the
// reading about its least-squares circle, i.e. less its mean and first harmonic. An error term's
// "part of G" is the same range of its fitted curve.
double range_about_circle(std::span<const double> angle_rad, std::span<const double> reading_um);
// A run's reading (um) about its least-squares circle: the fitted mean (the circle's radius change),
// its first harmonic (the centre's offset: cos_um along the first plane axis, sin_um the second) and
// what is left at each angle, the deviation a ballbar's polar plot draws. Empty with fewer than 4 points.
struct CircleFit {
  double mean_um = 0.0, cos_um = 0.0, sin_um = 0.0;
  std::vector<double> deviation_um;
};
CircleFit least_squares_circle(std::span<const double> angle_rad, std::span<const double> reading_um);

// A least-squares fit of the identification could not be solved (a non-finite value reached it, too few samples
// for its columns): the solver's failure, not the runs' (formats::DbbRunFormatError).
class FitError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws formats::DbbRunFormatError for unusable runs (none, mixed planes, invalid runs), std::invalid_argument
// for a column fitted beside of the wrong size, FitError when a fit cannot be solved.
Identification identify(const std::vector<formats::DbbRun>& runs, const IdentifyOptions& options = {});

// Lai third-order parameters in SI (straightness coefficients in m^(1-k), angles in rad).
// Definitions (docs/conventions.md): about the circle centre, in the test plane (a, b) with normal n,
//   X straightness in b:  a1 a + a2 a^2 + a3 a^3       Y straightness in a:  b2 b^2 + b3 b^3
//   X straightness in n:  d1 a + d2 a^2 + d3 a^3       Y straightness in n:  e1 b + e2 b^2 + e3 b^3
//   Y roll (n displacement = a * (c0 + c1 b + c2 b^2))
//   fixed ball at circle centre + (e_x, e_y); scale S_x, S_y; backlash; servo lag difference.
struct Lai3Params {
  double e_x = 0, e_y = 0;
  double s_x = 1, s_y = 1;
  double a1 = 0, a2 = 0, a3 = 0;
  double b2 = 0, b3 = 0;
  double c0 = 0, c1 = 0, c2 = 0;
  double d1 = 0, d2 = 0, d3 = 0;
  double e1 = 0, e2 = 0, e3 = 0;
  double backlash_x = 0, backlash_y = 0;
  double servo_mismatch_s = 0;
};

// Exact bar-length change (m) of Lai's deformed geometry at commanded angle zeta (no linearisation):
// the moving ball is displaced by the parameters above and |r1 - r0*| - L0 is evaluated exactly.
double lai3_exact_dL(const Lai3Params& p, double radius_m, double height_m, int direction, double feed_m_per_s,
                     double zeta);

// The linearised characteristic functions (Lai Eq. 28 / Table 1 in our conventions), one column per
// Lai parameter, in the order of lai3_parameter_names(); SI units.
std::vector<std::string> lai3_parameter_names();
std::vector<double> lai3_characteristics(double radius_m, double height_m, int direction, double feed_m_per_s,
                                         double zeta);

}  // namespace guideway::models::dbb
