// speed_variation: the spindle turns faster or slower than its nominal speed, or drifts, so a reading's
// angle (from its time at the nominal rpm) slips against where the spindle really was.
#include <memory>
#include <tuple>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// An angle error d theta moves the once-per-revolution term a cos + b sin by (-a sin + b cos) d theta:
// its slope, from the base fitted to the rows in use, times the slip. The slip of a speed off by e (a
// fraction) is omega e t; of a ramp g (a fraction per second) omega g t^2 / 2. Columns per reported unit:
// percent and percent per minute.
Variant slip_variant(const std::vector<Rp>& g, const Eigen::VectorXd& coef, bool offset) {
  std::vector<std::string> names;
  if (offset) names.push_back(results::name(results::speed_offset));
  names.push_back(results::name(results::speed_ramp));
  return make_variant(g, std::move(names), [&coef, offset](const Rp& p, double* o) {
    const double slope = once_per_rev_slope(coef, p);
    if (offset) *o++ = slope * p.omega_rad_s * p.t_s * 0.01;
    *o = slope * p.omega_rad_s * 0.5 * p.t_s * p.t_s * 0.01 / 60.0;
  });
}

bool speed_variation_runout_term(const RunoutTerms& t, Candidate& c) {
  auto data = std::make_shared<const std::tuple<std::vector<Rp>, Block, Eigen::VectorXd>>(t.g, t.base, t.y_um);
  c.search_size = 2;
  c.generate = [data](const Eigen::VectorXd&, const std::vector<bool>& use) {
    const auto& [g, base, y] = *data;
    std::vector<Variant> out;
    const Eigen::VectorXd coef = base_coefficients(base, y, use);
    if (coef.size() == 0) return out;
    for (bool offset : {false, true}) out.push_back(slip_variant(g, coef, offset));
    return out;
  };
  return true;
}

}  // namespace

extern const Effect speed_variation{
    {"speed_variation",
     "the spindle's speed differs from the nominal or drifts during the record, so the angle taken from time slips",
     "time",
     "the once-per-revolution term drifting in phase, more the longer the record runs",
     {},
     {"runout"}},
    {},
    {},
    false,
    {"the spindle turns off its nominal speed or drifts (drive, load, warm-up): the angles the readings are given from "
     "their time slip, and the once-per-revolution term slides in phase through the record",
     &speed_variation_runout_term}};

}  // namespace guideway::models::explain::effects
