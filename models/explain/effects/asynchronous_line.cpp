// asynchronous_line: an error motion at a non-integer number of cycles per revolution (a rolling
// element's defect, the cage), found as the strongest line of the residual's periodogram in orders.
#include <cmath>
#include <memory>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

bool asynchronous_line_runout_term(const RunoutTerms& t, Candidate& c) {
  const OrderGrid grid = non_integer_orders(t);
  if (grid.size == 0) return false;
  c.search_size = grid.searched();
  auto g = std::make_shared<const std::vector<Rp>>(t.g);
  c.generate = [g, runs = t.runs, grid, revolutions = t.revolutions, highest = t.highest_order](
                   const Eigen::VectorXd& residual, const std::vector<bool>& use) {
    std::vector<Variant> out;
    const double order = strongest_order(*g, runs, grid, residual, use);
    if (!std::isfinite(order)) return out;
    const Block unused_base;
    const Eigen::VectorXd unused_y;
    const RunoutTerms terms{*g, runs, revolutions, highest, unused_base, unused_y};
    Variant v = line_variant(terms, order, results::asynchronous_line, results::asynchronous_line_phase);
    v.group = "order " + std::to_string(static_cast<long long>(std::llround(order / grid.resolution)));
    out.push_back(std::move(v));
    return out;
  };
  return true;
}

}  // namespace

extern const Effect asynchronous_line{
    {"asynchronous_line",
     "a rolling element's defect or the cage turns at a non-integer ratio to the spindle, so its error motion does not "
     "repeat every revolution",
     "spindle angle over revolutions",
     "a sinusoid at a non-integer number of cycles per revolution: a band that differs from revolution to revolution",
     {},
     {"runout"}},
    {},
    {},
    false,
    {"a line at a non-integer number of cycles per revolution, which no revolution repeats: the asynchronous error "
     "motion of a bearing (rolling element or cage)",
     &asynchronous_line_runout_term}};

}  // namespace guideway::models::explain::effects
