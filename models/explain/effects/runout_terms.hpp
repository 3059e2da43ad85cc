#pragma once
// What the spindle run-out terms of the effects are built from (runout_explain.cpp fills one per
// problem): the readings of the records with the spindle's nominal angle and time, and the base.

#include <cstddef>
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
};

struct RunoutTerms {
  const std::vector<Rp>& g;
  std::size_t runs = 1;
  double revolutions = 0.0;    // the shortest record's revolutions (the order resolution is 1 / revolutions)
  double highest_order = 0.0;  // the highest order searched (a quarter of the samples per revolution, at most 50)
  const Block& base;           // offset and once-per-revolution term per record
  const Eigen::VectorXd& y_um;
};

// A line at `order` per revolution: the columns sin(order theta), cos(order theta), one pair per record
// when there are several (each record starts at its own spindle angle and time, so a line keeps its
// amplitude from record to record but not its phase), reported as amplitude `amp` and phase `phase` (per
// record: names with _run1, _run2, ...) with the order as the searched value.
Variant line_variant(const RunoutTerms& t, double order, const results::Parameter& amp,
                     const results::Parameter& phase);

}  // namespace guideway::models::explain::effects
