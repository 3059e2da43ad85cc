#pragma once
// What the spindle run-out terms of the effects are built from (runout_explain.cpp fills one per
// problem): the readings of the records with the spindle's nominal angle and time, and the base; and the
// pieces several run-out effects share (a line's columns, the search over orders, the base's fit).

#include <cstddef>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "models/explain/explain.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

struct Rp {
  std::size_t run;
  double theta_rad;    // nominal spindle angle since the record's start (counted on over revolutions)
  double t_s;          // time since the record's start
  double omega_rad_s;  // the nominal angular speed (the record's rpm)
  double spindle_rad = 0.0;  // with a reversal: the angle from the spindle's zero, the same in every record
  double artifact_rad =
      0.0;  // with a reversal: how far the record's artifact is turned (its form reads at spindle - artifact)
};

struct RunoutTerms {
  const std::vector<Rp>& g;
  std::size_t runs = 1;
  double revolutions = 0.0;    // the shortest record's revolutions (the order resolution is 1 / revolutions)
  double highest_order = 0.0;  // the highest order searched (a quarter of the samples per revolution, at most 50)
  const Block& base;           // offset and once-per-revolution term per record
  const Eigen::VectorXd& y_um;
  // Records whose angles share the spindle's zero with the artifact turned between them (Donaldson's
  // reversal): a harmonic is the spindle's (fixed at its spindle angle) or the artifact's form (turning
  // with it), one pair of columns over every record each.
  bool reversal = false;
};

// A line at `order` per revolution: the columns sin(order theta), cos(order theta), one pair per record
// when there are several (each record starts at its own spindle angle and time, so a line keeps its
// amplitude from record to record but not its phase), reported as amplitude `amp` and phase `phase` (per
// record: names with _run1, _run2, ...) with the order as the searched value. `weight` (optional) scales
// each row's columns (a line that modulates something else, e.g. the once-per-revolution term's slope).
Variant line_variant(const RunoutTerms& t, double order, const results::Parameter& amp, const results::Parameter& phase,
                     const std::function<double(const Rp&)>& weight = {});

// With a reversal: a harmonic of `order` over every record at once, at the spindle's angle (the spindle's
// error motion) or, `turning`, at the artifact's (its form: spindle angle - the record's turn).
Variant reversal_line_variant(const RunoutTerms& t, int order, bool turning, const results::Parameter& amp,
                              const results::Parameter& phase);
// Whether a turn between the records moves the form of `order` by 60 deg or more in some record (at 180
// deg: the odd orders), so that the spindle's and the form's columns are told apart.
bool reversal_separates(const RunoutTerms& t, int order);

// Orders searched for a line that no revolution repeats: from 4 cycles over the record to the highest
// searched, 4 grid points per resolution 1/R (R revolutions), leaving out 1/R about each whole order.
struct OrderGrid {
  double lo = 0, step = 0, resolution = 0;
  std::size_t size = 0;
  [[nodiscard]] double at(std::size_t k) const { return lo + step * static_cast<double>(k); }
  [[nodiscard]] bool near_whole(double order) const;
  [[nodiscard]] std::size_t searched() const;  // the grid points not near a whole order
};
OrderGrid non_integer_orders(const RunoutTerms& t);
// The order of the strongest line of the residual (rows in use), each row weighted by `weight` (empty:
// 1), the records' powers summed, placed between grid points by a parabola; NaN when none is searched.
double strongest_order(const std::vector<Rp>& g, std::size_t runs, const OrderGrid& grid, const Eigen::VectorXd& r,
                       const std::vector<bool>& use, const std::vector<double>& weight = {});

// The base (offset and once-per-revolution term per record) fitted to the rows in use; empty when too few.
Eigen::VectorXd base_coefficients(const Block& base, const Eigen::VectorXd& y, const std::vector<bool>& use);
// d/dtheta of a record's once-per-revolution term a cos + b sin at a reading, from the base's coefficients:
// what an error of the reading's angle moves it by, per radian.
double once_per_rev_slope(const Eigen::VectorXd& coef, const Rp& p);

}  // namespace guideway::models::explain::effects
