#pragma once
// Explaining a mismatch between a model and a recording (docs/explain.md): locate where the residual of the
// base model is structured rather than noise, then find the set of candidate effects of the library
// (effects.hpp) that together explain it -- forward selection, each candidate fitted jointly with the
// base and the effects already taken and accepted when it passes an F-test (Bonferroni over the
// candidates and the variants searched), lowers the BIC and improves the held-out RMS; whenever an
// effect joins, the earlier ones have their variants re-chosen and must still pass the tests without
// it (drop-one); in the end every effect must remove most of the structure left without it -- and
// stop when nothing more is significant. What remains structured is reported as `unexplained`. The
// model-specific front ends (dbb_explain.hpp, profile_explain.hpp) build the Problem; this engine
// knows no physics; what it reports is explain_result.hpp. Pure functions; thread safe; throws
// std::invalid_argument.

#include <algorithm>
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "models/explain/explain_result.hpp"

namespace guideway::models::explain {

// One observation with the coordinates the locate step reports in.
struct Sample {
  std::size_t run = 0;  // index into Problem::runs; samples of a run are contiguous and in time order
  double y_um = 0.0;    // what is explained: the measurement (base refitted) or measured - simulated
  double where = 0.0;   // position in the problem's domain (angle_deg or position_mm)
  double t_s = 0.0;     // machine time, from the problem's earliest sample or run start
};

struct RunInfo {
  std::string label;
  int direction = 1;  // +1 / -1 (ccw / cw, or +x / -x)
  double feed_mm_per_min = 0.0;
  std::string geometry;  // runs with equal geometry are compared across direction and feed
  std::string source;    // the run's file or source, for the locations reported
  double start_s = 0.0;  // the run's time zero on the problems' time axis (Sample::t_s)
};

// Design columns in um per reported unit, one row per sample.
struct Block {
  std::vector<std::string> names;  // reported names with units (e.g. "servo_mismatch_ms")
  Eigen::MatrixXd columns;         // N x names.size()
};

// One concrete form of a candidate; nonlinear parameters (a period, a decay time, a frequency) are
// searched on a grid, each grid point a variant.
struct Variant {
  Block block;
  // Columns made on demand, set instead of block.columns (which is then empty): writes the block's columns, one
  // row per sample of the problem, into `out` (sized for them). For what a generator offers many of and is cheap
  // to make again (a sinusoid of a position or of time, a deadband's response): none of them is held, the engine
  // makes each where it uses it. The same columns every call.
  std::function<void(Eigen::Ref<Eigen::MatrixXd> out)> fill;
  std::vector<ParamValue> fixed;  // the searched values, reported with u = NaN
  std::size_t searched = 0;       // nonlinear parameters searched (counted in the BIC)
  // A candidate is taken at most once, unless its variants name groups: then once per group (a cyclic
  // error along each axis, a vibration along each direction).
  std::string group;
  // Reported parameters from the block's coefficients and their covariance; empty = the coefficients.
  std::function<std::vector<ParamValue>(const Eigen::VectorXd&, const Eigen::MatrixXd&)> report;
  // Set by the engine, not by a front end: when it has set samples aside (docs/explain.md step 5), the block over
  // every sample of the problem given to explain() (the block then holds the samples kept only). Empty otherwise.
  std::function<Eigen::MatrixXd()> all_samples;
  // Where a searched value is an end of its grid that the physics goes past (a stick-slip's 50 ms decay): the variants
  // a grid step past that end, its other values the same, not searched (a generator's made as its grid's are, from the
  // same residual). The variant is taken only where each of them fits worse beside the model, so that a value reported
  // is inside what was tried; where one fits better the optimum lies outside the grid, and a finding there is suspect
  // by construction (issue 41 item 10: a stick-slip "found" at its grid's edge on a machine without one). Empty:
  // every searched value inside its grid, or at a bound of the physics (no delay below 0) or of what data resolve.
  std::vector<Variant> beyond;
};
// A variant's number of columns; its columns written into `out` (one row per sample, width(v) columns); and
// its columns themselves, its block's or made into `scratch`.
Eigen::Index width(const Variant& v);
void write_columns(const Variant& v, Eigen::Ref<Eigen::MatrixXd> out);
const Eigen::MatrixXd& columns_of(const Variant& v, Eigen::Index rows, Eigen::MatrixXd& scratch);

struct Candidate {
  std::string effect;  // a name of effect_library()
  std::string why;     // one sentence of physics, for the report
  std::vector<Variant> variants;
  // Variants made from the current residual (e.g. the peaks of a periodogram) instead of a fixed list.
  // use[i] false: sample i is held out (its residual is 0); a generator must estimate from the others.
  std::function<std::vector<Variant>(const Eigen::VectorXd& residual_um, const std::vector<bool>& use)> generate;
  std::size_t search_size = 0;  // grid points searched, for the Bonferroni factor; 0 = variants.size()
};

struct Problem {
  std::string model;   // "dbb", "flatness", "straightness", "simulated"
  std::string domain;  // "angle_deg" or "position_mm"
  // false: no times were recorded, the samples' t_s count readings (a traverse without `t_s`): the locations
  // then speak of readings, never of seconds.
  bool timed = true;
  std::vector<Sample> samples;
  std::vector<RunInfo> runs;
  Block base;  // may have no columns (a given simulation: nothing is refitted)
  std::vector<Candidate> candidates;
  std::vector<std::string> notes;  // passed through to the report
  // Machine-clock time of t_s = 0 (NaN: the runs share no machine clock), for the locations reported.
  double clock_origin_s = std::numeric_limits<double>::quiet_NaN();
  // Some candidates have terms of one run alone (a drift offset or a vibration phase per run, when
  // runs share no clock): such a term cannot predict a run held out whole, so held-out rows are then
  // blocks of every run, whatever the number of runs.
  bool terms_per_run = false;
  // Each sample's station (its place on the grid the runs revisit, 0 = the lowest), for a base that is a
  // function of position (a traverse's geometry). Set: held-out rows are interleaved along the stations,
  // never a block at a run's end, where a fold would extrapolate the base (docs/explain.md "Held out").
  std::vector<std::size_t> station_of;
  // Set with station_of: the base holds a term per station, fitted out of the data rather than given as columns
  // (a traverse's geometry where its passes revisit the stations: thousands of columns, which the engine would factor
  // per fold). The samples' y and every candidate's columns are given less their station's mean, which is that fit
  // (Frisch-Waugh-Lovell: the same coefficients, residual and RSS as with the columns); the models count a rank per
  // station, the held-out folds hold whole stations (a station's readings are all held out or all kept: what is
  // predicted is how they disagree), and after a place is set aside the samples kept are absorbed again
  // (absorb_station_means(Problem&) sets it).
  bool station_means_absorbed = false;
  // Runs that continue one path, one id per run (a traverse's passes of one file: the reflector goes back and forth
  // along the same stations); empty: every run stands alone. A path with a run shorter than min_run_samples
  // (locate.hpp) has its runs tested together, joined in the order taken (docs/explain.md "Short passes").
  std::vector<std::size_t> path_of_run;
  // The yardstick the findings' contributions are given against (um; NaN = none): for DBB runs the
  // largest circular deviation G of a run, as a ballbar's software ranks errors.
  double deviation_um = std::numeric_limits<double>::quiet_NaN();
  std::string deviation_name;  // e.g. "circular deviation G"
  // A finding's part of that yardstick from its fitted term (one value per sample); unset: the term's
  // peak-to-valley over a run, the largest over the runs.
  std::function<double(const Eigen::VectorXd& term_um)> contribution_of;
};

// Helpers for the model front ends (dbb_explain, profile_explain).
// A variant whose block has one row per point, filled by row(point, out) into zeroed storage.
template <class Point, class RowFn>
void fill_rows(const std::vector<Point>& points, const RowFn& row, Eigen::Ref<Eigen::MatrixXd> out) {
  const Eigen::Index q = out.cols();
  std::vector<double> buf(static_cast<std::size_t>(q));
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::fill(buf.begin(), buf.end(), 0.0);
    row(points[i], buf.data());
    for (Eigen::Index k = 0; k < q; ++k) out(static_cast<Eigen::Index>(i), k) = buf[static_cast<std::size_t>(k)];
  }
}
template <class Point, class RowFn>
Variant make_variant(const std::vector<Point>& points, std::vector<std::string> names, const RowFn& row) {
  Variant v;
  v.block.names = std::move(names);
  v.block.columns.resize(static_cast<Eigen::Index>(points.size()), static_cast<Eigen::Index>(v.block.names.size()));
  fill_rows(points, row, v.block.columns);
  return v;
}
// The same made on demand (Variant::fill): the points shared, the row function kept.
template <class Point, class RowFn>
Variant make_lazy_variant(std::shared_ptr<const std::vector<Point>> points, std::vector<std::string> names, RowFn row) {
  Variant v;
  v.block.names = std::move(names);
  v.fill = [points = std::move(points), row = std::move(row)](Eigen::Ref<Eigen::MatrixXd> out) {
    fill_rows(*points, row, out);
  };
  return v;
}
// Amplitude and phase (deg) of A sin(theta + phi) = (A cos phi) sin theta + (A sin phi) cos theta from the
// coefficients (sin, cos) and their covariance, with first-order uncertainties.
std::vector<ParamValue> amp_phase(const std::string& amp_name, const std::string& phase_name, const Eigen::VectorXd& x,
                                  const Eigen::MatrixXd& cov);

// The indices of the rows in use (a generator's mask).
std::vector<Eigen::Index> rows_in_use(const std::vector<bool>& use);
// The base fitted to the rows in use only, predicted on every row (so a held-out row's y does not reach
// what is built from it); empty when the fit fails.
Eigen::VectorXd base_prediction(const Block& base, const Eigen::VectorXd& y_um, const std::vector<bool>& use);

// base_prediction of one base and what it explains, kept for the last few masks asked for: the generators of a
// problem that read the base's prediction (servo_lag, sensor_nonlinearity) are given the same masks -- every row,
// each fold's training rows -- again and again. Thread safe.
class BasePredictions {
 public:
  // The base's rows `rows` (nullptr: every row), each row the same whichever others are asked for.
  using BaseRows = std::function<Block(const std::vector<Eigen::Index>* rows)>;
  BasePredictions(Block base, Eigen::VectorXd y_um)
      : held_(std::make_shared<const Block>(std::move(base))), y_(std::move(y_um)) {}
  // The base made again each time it is needed (a mask not predicted lately) from what the problem holds anyway (a
  // DBB problem's Lai base from the samples' geometry), so that the problem holds its base once, not twice: first
  // the rows in use, fitted, then every row, predicted; never both at once.
  BasePredictions(BaseRows make_base, Eigen::VectorXd y_um) : make_(std::move(make_base)), y_(std::move(y_um)) {}
  // Empty when the fit fails.
  [[nodiscard]] std::shared_ptr<const Eigen::VectorXd> of(const std::vector<bool>& use) const;
  [[nodiscard]] Eigen::Index rows() const { return y_.size(); }
  [[nodiscard]] const Eigen::VectorXd& y() const { return y_; }
  [[nodiscard]] Block base() const { return held_ ? *held_ : make_(nullptr); }

 private:
  [[nodiscard]] Eigen::VectorXd predict(const std::vector<bool>& use) const;
  static constexpr std::size_t kept = 10;  // masks: every row and 8 folds, and one more
  std::shared_ptr<const Block> held_;
  BaseRows make_;
  Eigen::VectorXd y_;
  mutable std::mutex mutex_;
  mutable std::vector<std::pair<std::vector<bool>, std::shared_ptr<const Eigen::VectorXd>>> recent_;  // latest last
};

// sensor_nonlinearity's block: (reading - mean)^2 and (reading - mean)^3 per sample, the reading being
// the sensor's operating point.
Variant sensor_nonlinearity_variant(const std::vector<double>& reading_um);
// The same block with the reading the base predicts (plus offset_um per sample, e.g. a measured
// straightness; empty = none), the base fitted to the rows in use only: held-out y does not reach the
// columns. With every row in use it equals sensor_nonlinearity_variant(y - base fit residual + offset).
std::function<std::vector<Variant>(const Eigen::VectorXd&, const std::vector<bool>&)> sensor_nonlinearity_generator(
    const Block& base, const Eigen::VectorXd& y_um, std::vector<double> offset_um);
// The same from predictions shared with the problem's other generators.
std::function<std::vector<Variant>(const Eigen::VectorXd&, const std::vector<bool>&)> sensor_nonlinearity_generator(
    std::shared_ptr<const BasePredictions> base, std::vector<double> offset_um);
// Each column of x less its station's mean over the rows `keep` keeps (nullptr: every row), on every row; a station
// with no row kept is zeroed (its term fits it whole). A column left at rounding of what it was (a function of the
// station, to 1e-9 relative) is zeroed: nothing of it is beyond the stations' terms.
void absorb_station_means(const std::vector<std::size_t>& station_of, const std::vector<bool>* keep,
                          Eigen::Ref<Eigen::MatrixXd> x);
// A problem's term per station fitted out (Problem::station_means_absorbed): its samples' y, its base's columns and
// every candidate's columns (listed, made on demand or generated) less their station's mean over its samples.
void absorb_station_means(Problem& problem);
Report explain(const Problem& problem, const ExplainOptions& options = {});

}  // namespace guideway::models::explain
