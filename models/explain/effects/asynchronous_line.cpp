// asynchronous_line: an error motion at a non-integer number of cycles per revolution (a rolling
// element's defect, the cage), found as the strongest line of the residual's periodogram in orders.
#include <algorithm>
#include <cmath>
#include <complex>
#include <memory>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// Orders from 4 cycles over the record to the highest searched, 4 grid points per resolution 1/R
// (R revolutions), leaving out 1/R about each whole order (what repeats every revolution is
// synchronous_harmonic's).
struct OrderGrid {
  double lo = 0, step = 0, resolution = 0;
  std::size_t size = 0;
  [[nodiscard]] double at(std::size_t k) const { return lo + step * static_cast<double>(k); }
  [[nodiscard]] bool near_whole(double order) const { return std::abs(order - std::round(order)) < resolution; }
};

// The power of the residual (rows in use) at orders lo + k step, the records' powers summed.
std::vector<double> periodogram(const std::vector<Rp>& g, std::size_t runs, const OrderGrid& grid,
                                const Eigen::VectorXd& r, const std::vector<bool>& use) {
  std::vector<std::complex<double>> acc(grid.size * runs);
  for (std::size_t i = 0; i < g.size(); ++i) {
    if (!use[i]) continue;
    const double th = g[i].theta_rad;
    std::complex<double> z = std::polar(r[static_cast<Eigen::Index>(i)], -grid.lo * th);
    const std::complex<double> step = std::polar(1.0, -grid.step * th);
    std::complex<double>* a = acc.data() + g[i].run * grid.size;
    for (std::size_t k = 0; k < grid.size; ++k, z *= step) a[k] += z;
  }
  std::vector<double> power(grid.size, 0.0);
  for (std::size_t run = 0; run < runs; ++run)
    for (std::size_t k = 0; k < grid.size; ++k) power[k] += std::norm(acc[run * grid.size + k]);
  return power;
}

bool asynchronous_line_runout_term(const RunoutTerms& t, Candidate& c) {
  OrderGrid grid;
  grid.resolution = 1.0 / t.revolutions;
  grid.lo = 4.0 * grid.resolution;
  grid.step = grid.resolution / 4.0;
  if (t.highest_order <= grid.lo) return false;
  grid.size = static_cast<std::size_t>(std::floor((t.highest_order - grid.lo) / grid.step)) + 1;
  std::size_t searched = 0;
  for (std::size_t k = 0; k < grid.size; ++k) searched += grid.near_whole(grid.at(k)) ? 0 : 1;
  c.search_size = searched;
  auto g = std::make_shared<const std::vector<Rp>>(t.g);
  c.generate = [g, runs = t.runs, grid, revolutions = t.revolutions, highest = t.highest_order](
                   const Eigen::VectorXd& residual, const std::vector<bool>& use) {
    const std::vector<double> power = periodogram(*g, runs, grid, residual, use);
    std::size_t best = grid.size;
    for (std::size_t k = 0; k < grid.size; ++k)
      if (!grid.near_whole(grid.at(k)) && (best == grid.size || power[k] > power[best])) best = k;
    std::vector<Variant> out;
    if (best == grid.size) return out;
    // Placed between grid points: the peak of the parabola through the best point and its neighbours.
    double order = grid.at(best);
    if (best > 0 && best + 1 < grid.size) {
      const double a = power[best - 1], b = power[best], d = power[best + 1];
      const double den = a - 2 * b + d;
      if (den < 0) order += grid.step * std::clamp(0.5 * (a - d) / den, -0.5, 0.5);
    }
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
