#pragma once
// Workpiece flatness analysis (Mu 2012, Secs. 3-4.4): which carriage error shows on a faced part.
// A profile of the faced surface (x along the radius = machine X) is decomposed with a Daubechies
// wavelet (Eq. 18: x = s1 + s2, s1 = the approximation at the deepest level); the two simulated
// components of Eq. 16 are y1 = squareness (Eq. 15, a line in x) and y2 = straightness of the X
// carriage (the Eq. 10 polynomial fitted to an autocollimator traverse, evaluated at the profile's x);
// Pearson coefficients of x and of s1 with each (Eqs. 19, 20) name the dominant error, whose impact
// factor is its coefficient after the wavelet step. The squareness is identified from the profile
// with the straightness removed (least-squares slope), with its uncertainty, and checked against a
// run-out revolution (Eq. 21). Pure functions (file reading aside); thread safe. SI inside.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "models/flatness/runout.hpp"
#include "models/flatness/straightness.hpp"

namespace guideway::models::flatness {

// One measured profile of the faced workpiece (SI), equally spaced in x.
struct WorkpieceProfile {
  std::string source;
  double feed_m_per_s = 0.0;
  double spindle_rpm = 0.0;
  std::vector<double> x_m;
  std::vector<double> z_m;
};

// Reads a `guideway/profile/1` CSV (docs/formats.md): x_mm,z_um (other units as that format allows),
// metadata feed_mm_per_min and spindle_rpm required; every point valid (no NaN), equally spaced
// increasing x, at least 64 points. Throws CsvError "file[:line]: message".
WorkpieceProfile parse_workpiece_profile(std::string_view text, const std::string& source);
WorkpieceProfile read_workpiece_profile(const std::string& path);

struct WorkpieceFlatnessOptions {
  std::string wavelet = "db1";  // Mu: db1
  int levels = 5;               // Mu: 5 levels; s1 = the approximation A_levels
  int monte_carlo = 100;        // traverse replicates for the straightness part of u(squareness); fixed seed
};

// Eqs. 19 and 20 for one simulated component.
struct ComponentCorrelation {
  std::string name;           // "squareness" (y1) | "straightness" (y2)
  double gamma_before = 0.0;  // Eq. 19: profile x with y_m
  double gamma_after = 0.0;   // Eq. 20: low-frequency part s1 with y_m
};

// One profile analysed; a value type.
struct ProfileFlatness {
  std::string source;
  double feed_m_per_s = 0.0;
  double spindle_rpm = 0.0;
  std::size_t points = 0;
  double spacing_m = 0.0;
  double x_start_m = 0.0;
  double x_end_m = 0.0;
  double peak_to_valley_m = 0.0;                   // of the measured profile (the out-of-flatness)
  double low_frequency_peak_to_valley_m = 0.0;     // of s1
  std::vector<double> band_rms_m;                  // rms of each MRA component, [A_J, D_J, ..., D_1]
  std::vector<ComponentCorrelation> correlations;  // y1 then y2
  std::string dominant;                            // name of the component with the largest |gamma_after|
  double impact_factor = 0.0;                      // its gamma_after
  // Squareness from the profile: z - y2 = c + q (x - x_start), least squares. q > 0: the surface
  // rises towards +x (the spindle leans towards +x, simulators::machine::SpindleErrors::tilt_x_rad).
  double squareness_rad = 0.0;
  double u_squareness_rad = 0.0;    // sqrt(u_fit^2 + u_straightness^2)
  double u_fit_rad = 0.0;           // profile noise, inflated for residual autocorrelation
  double u_straightness_rad = 0.0;  // from the traverse (Monte Carlo over its angle noise)
  double residual_rms_m = 0.0;
  double residual_lag1_correlation = 0.0;  // rho used for the inflation sqrt((1 + rho) / (1 - rho))
  double squareness_amplitude_m = 0.0;     // |q| * (x_end - x_start), Eq. 15 over the profile
  double u_squareness_amplitude_m = 0.0;
};

// Eq. 21 against the squareness identified from the profiles.
struct RunoutCrossCheck {
  RunoutResult runout;
  double profile_squareness_rad = 0.0;  // |q| (Eq. 21 gives a magnitude)
  double u_profile_squareness_rad = 0.0;
  double difference_rad = 0.0;  // |q| - theta_0
  double u_difference_rad = 0.0;
  bool consistent = false;  // |difference| <= 2 u_difference
};

struct WorkpieceFlatnessResult {
  std::string wavelet;
  int levels = 0;
  std::string straightness_source;
  PolynomialFit straightness;  // y2's polynomial (vertical plane of the traverse), x from straightness_x0_m
  double straightness_x0_m = 0.0;
  double straightness_x_end_m = 0.0;
  std::vector<ProfileFlatness> profiles;
  // Combined squareness of all profiles: weighted mean of q (weights 1/u_fit^2), the straightness
  // part of u counted once (it is common to all profiles).
  double squareness_rad = 0.0;
  double u_squareness_rad = 0.0;
  double travel_m = 0.0;  // longest profile span
  double squareness_amplitude_m = 0.0;
  double u_squareness_amplitude_m = 0.0;
  std::string dominant;  // over all profiles: the component with the largest mean |gamma_after|
  double impact_factor = 0.0;
  std::optional<RunoutCrossCheck> runout_check;
};

// Throws CsvError when a profile leaves the traverse's x range, std::invalid_argument for bad
// options (unknown wavelet, levels < 1, too few points for the levels).
WorkpieceFlatnessResult analyse_workpiece_flatness(const std::vector<WorkpieceProfile>& profiles,
                                                   const AngleTraverse& traverse,
                                                   const std::optional<RunoutRevolution>& runout = std::nullopt,
                                                   const WorkpieceFlatnessOptions& options = {},
                                                   const StraightnessOptions& straightness = {});

}  // namespace guideway::models::flatness
