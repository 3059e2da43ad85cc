#pragma once
// What identify's fits are built from and share (models/dbb, identify.hpp): the per-sample points of the runs
// (geometry, weights, the backlash column's shape), the terms fitted beside a model's own, the deadband of the
// drives, preliminary fits on every stride-th point, the bar length's part of every u, a term's part of the
// circular deviation, and the error a fit that cannot be solved throws. Pure functions; thread safe.

#include <cstddef>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "formats/dbb_run.hpp"
#include "models/common/least_squares.hpp"
#include "models/dbb/geometry.hpp"
#include "models/dbb/identify.hpp"

namespace guideway::models::dbb::fitting {

inline constexpr double pi = std::numbers::pi;
inline constexpr double nan = std::numeric_limits<double>::quiet_NaN();

// Per-sample geometry and what the fits add to it.
struct Point : SampleGeometry {
  double bl_a = 0, bl_b = 0;      // lost motion per unit backlash: -sgn/2 for an ideal step, or the
                                  // deadband response at the current backlash estimate
  double cyc_sa = 0, cyc_ca = 0;  // sin and cos of the cyclic phase 2 pi a_m / period_a (and b),
  double cyc_sb = 0, cyc_cb = 0;  // once the periods are chosen (set_cyclic_phases)
  double w = 1;
  std::size_t sample = 0;  // among all the runs identified: the row of IdentifyOptions::beside's columns
  // 0 when no run passes a reversal of the axis (a partial arc: arcs.hpp): its reversal terms' columns
  // are then zero, so the fits refuse them by name instead of reading them from the arc's ends.
  double rev_a = 1, rev_b = 1;
};

// The ideal step: the axis trails the command by half the backlash, on the side it comes from.
void set_step_backlash(Point& p);

// The points of `runs`; run k's first sample is sample first_sample[k] of all the runs identified (none
// given: the runs are all of them). Each run's samples weigh as its sampling density along the arc it covers.
std::vector<Point> points_of(const std::vector<formats::DbbRun>& runs,
                             const std::vector<std::size_t>& first_sample = {});

// The columns of the terms fitted beside a model's own (all of them, or those the diagnostics do not hold),
// with their names.
struct BesideColumns {
  std::vector<const std::vector<double>*> columns;
  std::vector<std::string> names;
  [[nodiscard]] std::size_t size() const { return columns.size(); }
  [[nodiscard]] double at(std::size_t c, const Point& p) const { return (*columns[c])[p.sample]; }
};
BesideColumns beside_columns(const IdentifyOptions& options, bool diagnostics);

// The points' backlash column: the deadband of width b_a / b_b (m) on the drives' track (the one deadband
// EXPLAIN's backlash effect uses: geometry.hpp), the ideal step for a width <= 0.
void set_deadband(std::vector<Point>& pts, const DriveTrack& track, double b_a, double b_b);

// The deadband a fit reads: its widths (m) and the drives' delay behind the commanded angles (s).
struct Deadband {
  double b_a = 0, b_b = 0;
  std::size_t track = 0;  // index into the tracks (their delay_s)
  [[nodiscard]] bool shaped() const { return b_a > 0 || b_b > 0; }
};

// The deadband of widths `widths` that fits best: at every drive delay of `tracks` the points get its shape
// and `rms(pts)` (a fit's residual RMS) is evaluated; the lowest wins, and the points keep its shape. With
// one track (the angles are the encoders') only the widths are set.
template <class RmsOf>
Deadband choose_deadband_delay(std::vector<Point>& pts, const std::vector<DriveTrack>& tracks, Deadband widths,
                               const RmsOf& rms) {
  widths.b_a = std::max(widths.b_a, 0.0);
  widths.b_b = std::max(widths.b_b, 0.0);
  if (widths.shaped() && tracks.size() > 1) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < tracks.size(); ++k) {
      set_deadband(pts, tracks[k], widths.b_a, widths.b_b);
      const double e = rms(pts);
      if (e < best) {
        best = e;
        widths.track = k;
      }
    }
  }
  set_deadband(pts, tracks[widths.track], widths.b_a, widths.b_b);
  return widths;
}

FitSummary summary_of(const LsqResult& res);

// The result of a fit identify needs; throws FitError with its message when it could not be solved.
LsqResult solved(LsqResult res);

// Rows a preliminary fit on every stride-th point uses: all n when that would leave too few for
// `cols` parameters.
Eigen::Index strided_rows(Eigen::Index n, Eigen::Index cols, Eigen::Index stride);
// Least squares on every stride-th row only (a preliminary fit whose estimates steer a search or a
// basis shape); the residual is then evaluated on all rows.
LsqResult solve_strided(const Eigen::Ref<const Eigen::MatrixXd>& j, const Eigen::VectorXd& y, const Eigen::VectorXd& w,
                        const std::vector<std::string>& names, Eigen::Index stride);

// The bar's calibrated length is in every reading: its standard uncertainty u_length_um added to each
// parameter's u and to the covariance, as the fit's response to that offset (docs/conventions.md).
void add_bar_length_uncertainty(LsqResult& res, const Eigen::Ref<const Eigen::MatrixXd>& j, const Eigen::VectorXd& w,
                                const std::vector<std::string>& names, double u_length_um);

// The design matrix buffer of all fits of one identification (n rows, as many columns as the widest
// fit: one allocation, its pages touched once) and the data of the diagnostics fits.
struct FitWork {
  Eigen::MatrixXd j;
  Eigen::VectorXd y, w;
};

// ISO 230-4 circular deviation of one run (its points start at `p`, n of them) about its
// least-squares circle.
double circular_deviation(const Point* p, std::size_t n_points);
// A term's part of the circular deviation: per run, the range of its curve (values per point, in run
// order) about the least-squares circle; the largest over the runs.
double part_of_deviation(const std::vector<Point>& pts, const std::vector<double>& curve, std::size_t runs);

inline Estimate est(const std::string& name, double value, double u, bool fitted = true) {
  return {name, value, u, fitted};
}

// The terms fitted beside (columns [first, end) of the fit) as reported: each identified column, then each
// line among them (a vibration's or cyclic error's sine and cosine parts) as its amplitude and phase, with
// u from the parts' covariance.
void add_beside(const LsqResult& res, const std::vector<std::string>& names, std::size_t first, std::size_t end,
                std::vector<Estimate>& beside);

}  // namespace guideway::models::dbb::fitting
