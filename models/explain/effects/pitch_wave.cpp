// pitch_wave: the carriage pitches periodically along the axis (a rack's teeth, a lead screw's long wave),
// found as the strongest line of the residual's periodogram along the axis.
#include <algorithm>
#include <cmath>
#include <complex>
#include <memory>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/traverse_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// Spatial frequencies (cycles per metre) from 1.5 cycles over the stations (longer waves are what the
// base's polynomial takes) to 2.5 station pitches a cycle (below the stations' Nyquist), 4 grid points
// per resolution 1/span.
struct WaveGrid {
  double lo = 0, step = 0;
  std::size_t size = 0;
  [[nodiscard]] double at(std::size_t k) const { return lo + step * static_cast<double>(k); }
};

std::vector<double> periodogram(const std::vector<Tp>& g, const WaveGrid& grid, const Eigen::VectorXd& r,
                                const std::vector<bool>& use) {
  std::vector<std::complex<double>> acc(grid.size);
  for (std::size_t i = 0; i < g.size(); ++i) {
    if (!use[i]) continue;
    const double th = 2 * pi * g[i].x_m;
    std::complex<double> z = std::polar(r[static_cast<Eigen::Index>(i)], -grid.lo * th);
    const std::complex<double> step = std::polar(1.0, -grid.step * th);
    for (std::size_t k = 0; k < grid.size; ++k, z *= step) acc[k] += z;
  }
  std::vector<double> power(grid.size);
  for (std::size_t k = 0; k < grid.size; ++k) power[k] = std::norm(acc[k]);
  return power;
}

Variant wave_variant(const std::vector<Tp>& g, double cycles_per_m) {
  Variant v = make_variant(g, {results::name(results::pitch_wave_sin), results::name(results::pitch_wave_cos)},
                           [cycles_per_m](const Tp& p, double* o) {
                             const double th = 2 * pi * cycles_per_m * p.x_m;
                             o[0] = std::sin(th) * urad_per_arcsec;
                             o[1] = std::cos(th) * urad_per_arcsec;
                           });
  v.fixed.push_back(
      {results::name(results::pitch_wave_period), 1e3 / cycles_per_m, std::numeric_limits<double>::quiet_NaN()});
  v.searched = 1;
  v.report = [](const Eigen::VectorXd& x, const Eigen::MatrixXd& cov) {
    return amp_phase(results::name(results::pitch_wave), results::name(results::pitch_wave_phase), x, cov);
  };
  return v;
}

bool pitch_wave_traverse_term(const TraverseTerms& t, Candidate& c) {
  if (!(t.span_m > 0 && t.step_m > 0)) return false;
  WaveGrid grid;
  grid.lo = 1.5 / t.span_m;
  grid.step = 0.25 / t.span_m;
  const double hi = 1.0 / (2.5 * t.step_m);
  if (hi <= grid.lo) return false;
  grid.size = static_cast<std::size_t>(std::floor((hi - grid.lo) / grid.step)) + 1;
  c.search_size = grid.size;
  auto g = std::make_shared<const std::vector<Tp>>(t.g);
  c.generate = [g, grid](const Eigen::VectorXd& residual, const std::vector<bool>& use) {
    const std::vector<double> power = periodogram(*g, grid, residual, use);
    const auto best = static_cast<std::size_t>(std::max_element(power.begin(), power.end()) - power.begin());
    // Placed between grid points: the peak of the parabola through the best point and its neighbours.
    double f = grid.at(best);
    if (best > 0 && best + 1 < grid.size) {
      const double a = power[best - 1], b = power[best], d = power[best + 1];
      const double den = a - 2 * b + d;
      if (den < 0) f += grid.step * std::clamp(0.5 * (a - d) / den, -0.5, 0.5);
    }
    std::vector<Variant> out;
    out.push_back(wave_variant(*g, f));
    return out;
  };
  return true;
}

}  // namespace

extern const Effect pitch_wave{
    {"pitch_wave",
     "the carriage pitches periodically as it runs (a rack's teeth, a lead screw's or a pinion's once-per-turn "
     "wave)",
     "axis position",
     "a sinusoid along the axis, the same forward and back, at a period shorter than the traverse",
     {},
     {"traverse"}},
    {},
    {},
    false,
    {},
    {"the carriage pitches with a period along the axis (rack, lead screw, pinion): a wave every pass repeats at the "
     "same stations, in both directions",
     &pitch_wave_traverse_term}};

}  // namespace guideway::models::explain::effects
