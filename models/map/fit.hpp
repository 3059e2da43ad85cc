#pragma once
// One model of the machine from the day's tests (docs/map.md "The fit"): every test's readings are
// observations of the map through the kinematic chain (models/map/error_map), fitted together by weighted
// least squares with each test's set-up terms (an artifact's alignment, a traverse's zero per pass and its
// drift, a ballbar run's centre and length, the axes' backlash and play) beside them. Each function's
// Legendre orders are chosen by BIC; each test's noise is estimated from its own residuals (variance
// components), so the uncertainties are those of what was measured. What no test of the day can see is not
// fitted and is said, with the test that would determine it. Cross-checks where tests overlap.
// Pure functions; thread safe.

#include <string>
#include <vector>

#include "models/map/error_map.hpp"
#include "models/map/map_inputs.hpp"

namespace guideway::models::map {

struct FitOptions {
  int max_order = 6;                          // highest Legendre order tried per function
  int margin_orders = 1;                      // orders kept beyond BIC's choice (docs/map.md "Orders")
  std::size_t ballbar_samples_per_run = 720;  // a run's readings taken evenly down to this many
  int gauss_newton_iterations = 3;            // the chain is exact: its linearisation is iterated
  bool cross_checks = true;
};

// How one test's readings sat in the fit.
struct GroupSummary {
  std::string test;  // "artifact X displacements", "traverse Y", "ballbar xy"
  std::string unit;  // of the two figures below: "um", "arcsec"
  std::size_t observations = 0;
  double residual_rms = 0.0;  // of the readings about the map (and the test's set-up terms)
  double sigma = 0.0;         // the noise the fit estimated for one reading (its weight)
};

// Two determinations of one quantity by different tests, compared within their uncertainties (k = 2).
struct CrossCheck {
  std::string name;       // "pitch of X (EBX)", "straightness_x_um in xy", "squareness xz"
  std::string first;      // which test gave `value_first` ("traverse X")
  std::string second;     // and `value_second` ("artifact X")
  std::string unit;       // "um", "urad", "ppm"
  double value_first = 0.0, u_first = 0.0;    // for a function: its RMS over the travel
  double value_second = 0.0, u_second = 0.0;
  double difference = 0.0;  // for a function: the RMS over the travel of the two functions' difference
  double u_difference = 0.0;
  bool consistent = true;  // difference <= 2 u_difference
  std::string note;
};

// An axis' lost motion from the ballbar planes that see it (their inverse-variance mean; not one of the 21
// errors: the per-joint tables' forward and reverse columns hold it).
struct AxisBacklash {
  int axis = 0;
  double value_m = 0.0;
  double u_m = 0.0;
  std::string from;  // "ballbar xy + ballbar xz"
};

struct MapFit {
  ErrorMap map;
  std::vector<AxisBacklash> backlash;
  std::vector<GroupSummary> groups;
  std::vector<CrossCheck> checks;
  std::vector<std::string> notes;
};

// Throws std::invalid_argument when there is nothing to fit (no test) or a test is unusable (named).
MapFit fit_map(const MapInputs& inputs, const FitOptions& options = {});

}  // namespace guideway::models::map
