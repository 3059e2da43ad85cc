// speed_ripple: the spindle's speed varies periodically (a drive's torque ripple, a belt, a control loop),
// so the angle a reading is given from its time slips back and forth against where the spindle was.
#include <cmath>
#include <memory>
#include <tuple>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// A ripple of a (a fraction) at nu cycles per revolution, rpm (1 + a sin(nu theta)), slips the angle by
// a (1 - cos(nu theta)) / nu: the constant part moves the once-per-revolution term's phase (the base's),
// the rest moves the term by its slope times -a cos(nu theta) / nu, sidebands at 1 +- nu per revolution.
// The frequency: the strongest line of the residual weighted by that slope, at a non-integer order (a
// ripple locked to the revolution repeats every revolution: a synchronous harmonic). Columns per percent.
bool speed_ripple_runout_term(const RunoutTerms& t, Candidate& c) {
  const OrderGrid grid = non_integer_orders(t);
  if (grid.size == 0) return false;
  c.search_size = grid.searched();
  auto data = std::make_shared<const std::tuple<std::vector<Rp>, Block, Eigen::VectorXd>>(t.g, t.base, t.y_um);
  c.generate = [data, grid, runs = t.runs, revolutions = t.revolutions, highest = t.highest_order](
                   const Eigen::VectorXd& residual, const std::vector<bool>& use) {
    const auto& [g, base, y] = *data;
    std::vector<Variant> out;
    const Eigen::VectorXd coef = base_coefficients(base, y, use);
    if (coef.size() == 0) return out;
    std::vector<double> slope(g.size());
    for (std::size_t i = 0; i < g.size(); ++i) slope[i] = once_per_rev_slope(coef, g[i]);
    const double order = strongest_order(g, runs, grid, residual, use, slope);
    if (!std::isfinite(order)) return out;
    const Eigen::VectorXd unused_y;
    const RunoutTerms terms{g, runs, revolutions, highest, base, unused_y};
    out.push_back(line_variant(terms, order, results::speed_ripple, results::speed_ripple_phase,
                               [coef, order](const Rp& p) { return once_per_rev_slope(coef, p) * 0.01 / order; }));
    return out;
  };
  return true;
}

}  // namespace

extern const Effect speed_ripple{
    {"speed_ripple",
     "the spindle's speed varies periodically (a drive's torque ripple, a belt, the speed loop), so the angle taken "
     "from time slips back and forth",
     "time",
     "sidebands of the once-per-revolution term at 1 +- f per revolution, in the ratio its slope gives",
     {},
     {"runout"}},
    {},
    {},
    false,
    {"the spindle's speed ripples at a frequency of its drive: the angles the readings are given from their time slip "
     "back and forth, and the once-per-revolution term wobbles in phase",
     &speed_ripple_runout_term}};

}  // namespace guideway::models::explain::effects
