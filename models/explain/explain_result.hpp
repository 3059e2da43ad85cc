#pragma once
// What an explanation reports (models/explain, docs/explain.md): the baseline and final fits, where the
// residual is structured, the findings with their parameters, the candidates considered, the residual
// curves; and the report as text (as the EXPLAIN message's body: explanation.hpp). Without Eigen, for the
// sessions, the CLI and the scenario suite that only read reports.

#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace guideway::models::explain {

struct ParamValue {
  std::string name;
  double value = 0.0;
  double u = 0.0;  // standard uncertainty; NaN for a value found by search on a grid
};

struct ExplainOptions {
  double alpha = 1e-3;             // family-wise significance level of each selection step
  std::size_t max_effects = 6;     // at most this many findings
  std::size_t folds = 8;           // blocked cross-validation folds (when runs are not held out)
  double min_share = 0.8;          // share of the structure left without it that a finding must remove (a
                                   // partial fit of a cause it is not leaves that cause's shape behind)
  std::size_t curve_points = 720;  // residual curves in the report (0 = none)
  bool heldout_reselect = true;    // held-out RMS re-chooses every effect's variant in each fold from its
                                   // training rows; false: the variants chosen on all data (optimistic)
  bool keep_columns = false;       // each Finding keeps its term's columns (Finding::columns_um)
  // When the residual left is structured at a few places no effect explains (a step, a transient, a burst),
  // those places are set aside and the effects sought again in the rest, up to this share of the samples
  // (0: never).
  double max_set_aside = 0.3;
  // What the engine's caches may hold (MB): models and held-out fits kept for reuse. Beyond it they are
  // dropped and made again when needed (slower, the same results). 16: a fault beside backlash at 2 x 18,859
  // samples costs the same CPU as with 64, within the noise, and peaks 28 MB lower (bench/README.md).
  std::size_t memory_mb = 16;
  // What the engine is doing, at its steps (a candidate tried, a pass with places set aside), e.g. "looking
  // for effect 2: trying backlash (3 of 14)"; for a command's progress line. Empty: not called.
  std::function<void(const std::string&)> on_progress;
};

// A localized structure in every domain the user can act on: the run (and its file), the time from the
// run's start and on the machine clock, the place in the problem's domain, and whether another run has
// structure at the same place (position-bound) or not (it happened once).
struct Location {
  std::string run;                            // the run's label, e.g. "run2 (cw)"
  std::string source;                         // the run's file or source ("" when unknown)
  std::pair<double, double> where{0.0, 0.0};  // in the problem's domain (deg or mm)
  std::pair<double, double> t_from_run_start_s{0.0, 0.0};  // readings, not seconds, where !timed
  std::pair<double, double> t_machine_s{0.0, 0.0};  // NaN when the runs share no machine clock
  bool timed = true;                                // Problem::timed
  double peak_um = 0.0;
  std::vector<std::string> repeats_in;           // other runs with structure at the same place (empty: once)
  bool set_aside = false;                        // its samples were left out of the fit of the findings
  std::size_t first_sample = 0, end_sample = 0;  // [first, end) in the problem's samples (not reported)
};

struct Mismatch {
  std::string domain;
  std::string where;
  std::string band;
  std::string evidence;
  std::vector<std::pair<double, double>> ranges;  // the places in domain units (empty: throughout / n.a.)
  std::vector<Location> locations;                // the places run by run (localized structure only)
};

struct Finding {
  std::string effect;
  std::vector<ParamValue> parameters;
  double delta_bic = 0.0;
  double p_value = 1.0;  // Bonferroni-adjusted F-test
  double rms_um_after = 0.0;
  double heldout_rms_um_after = 0.0;
  double share = 0.0;            // of the visible structure removed (NaN when none was visible)
  double contribution_um = 0.0;  // its fitted term's size: Problem::contribution_of, else its peak-to-valley
  double contribution_percent = std::numeric_limits<double>::quiet_NaN();  // of Problem::deviation_um
  std::string why;
  // With ExplainOptions::keep_columns, the finding's term as it was fitted: its columns (um per unit, one
  // value per sample in the problem's order) and their names, for a model that fits it beside its own
  // terms (models/compensation). Not in the JSON.
  std::vector<std::string> column_names;
  std::vector<std::vector<double>> columns_um;
};

// A candidate's test in the last selection round (why it was not taken).
struct Considered {
  std::string effect;
  double delta_bic = 0.0;
  double p_value = 1.0;
  std::string verdict;
};

struct FitStats {
  double rms_um = 0.0;
  double bic = 0.0;
  double heldout_rms_um = 0.0;
  std::size_t parameters = 0;
};

struct ResidualStep {
  std::string label;                             // "base model", "+ backlash", ...
  std::vector<std::vector<double>> residual_um;  // one curve per run of Report::curve_runs
};

struct Report {
  std::string model;
  std::size_t n = 0;
  std::size_t set_aside = 0;   // samples of localized structure no effect explains, left out of the findings' fit
  double noise_um = 0.0;       // from the finest wavelet details of the baseline residual
  std::string heldout_scheme;  // "leave-one-run-out" or "blocked k-fold (k=8)"
  FitStats baseline;
  std::vector<Mismatch> mismatch;  // where the baseline residual is structured
  std::vector<Finding> findings;
  std::vector<Considered> considered;
  FitStats final_fit;
  std::vector<Mismatch> remaining;  // where the final residual is still structured
  bool unexplained = false;
  double deviation_um = std::numeric_limits<double>::quiet_NaN();  // Problem::deviation_um
  std::string deviation_name;
  std::vector<std::string> notes;
  // Residual curves for plots (docs/explain.md "residuals"): one x grid (the first run's, in the
  // problem's domain, increasing, at most ExplainOptions::curve_points), the runs drawn, and per step --
  // the base model, then after each finding in turn (base + findings 1..k fitted jointly) -- every
  // run's residual interpolated onto the grid.
  std::string curve_domain;
  std::vector<double> curve_x;
  std::vector<std::string> curve_runs;
  std::vector<ResidualStep> curve_steps;
};

// A readable explanation for a metrologist.
std::string to_text(const Report& report);

}  // namespace guideway::models::explain
