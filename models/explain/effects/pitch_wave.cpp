// pitch_wave: the carriage pitches periodically along the axis (a rack's teeth, a lead screw's long wave),
// found as the strongest line of the residual's periodogram along the axis.
#include <algorithm>
#include <cmath>
#include <complex>
#include <memory>
#include <mutex>

#include <unsupported/Eigen/FFT>

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

// The periodogram sum_i |r_i exp(-2 pi i f x_i)|^2 at the grid's frequencies, directly: n x grid points (the grid
// grows with the stations, so this is quadratic in them).
std::vector<double> direct_periodogram(const std::vector<Tp>& g, const WaveGrid& grid, const Eigen::VectorXd& r,
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

// The same periodogram by one FFT where the readings sit on the stations' grid x0 + m s (a traverse's do: its
// feet are one step apart) and the grid's frequencies are bins of a DFT of length M = 4 span / s (lo = 6 / (M s),
// step = 1 / (M s)): the residual summed per station, zero-padded to M. Exact where the positions are (the same
// sum in another order, rounding apart: ~1e-12 of the power); positions written to a few digits, or a real
// profile's 9,230 readings against its median step (0.1 nm off its mean: 1.1e-3 of a step at the far end), are
// within 1e-2 of a step of their station, and the frequencies within 1e-2 of a bin, which moves a line's phase by
// 0.025 rad at most and its power by ~3e-4. Linear in the readings but for the FFT's M log M; the direct sum's cost
// grows with the readings times the stations (9,230 readings: 5 s of CPU over a pass of EXPLAIN).
class StationSpectrum {
 public:
  StationSpectrum(const std::vector<Tp>& g, const WaveGrid& grid, double span_m, double step_m) {
    if (g.empty() || !(step_m > 0)) return;
    const double m_exact = 4.0 * span_m / step_m;
    const auto m = static_cast<std::size_t>(std::llround(m_exact));
    // The grid's frequencies the DFT's bins to within 1e-2 of a bin at both its ends, every reading on a station to
    // within 1e-2 of a step.
    if (m < 8 || 6 + grid.size > m / 2) return;
    const auto bin_of = [&](std::size_t k) { return grid.at(k) * static_cast<double>(m) * step_m; };
    if (std::abs(bin_of(0) - 6.0) > 1e-2 ||
        std::abs(bin_of(grid.size - 1) - 6.0 - static_cast<double>(grid.size - 1)) > 1e-2)
      return;
    double x0 = g.front().x_m;
    for (const Tp& p : g) x0 = std::min(x0, p.x_m);
    station_.reserve(g.size());
    for (const Tp& p : g) {
      const double k = (p.x_m - x0) / step_m;
      const double kr = std::round(k);
      if (std::abs(k - kr) > 1e-2 || kr >= static_cast<double>(m)) {
        station_.clear();
        return;
      }
      station_.push_back(static_cast<std::size_t>(kr));
    }
    size_ = m;
    fft_.SetFlag(Eigen::FFT<double>::HalfSpectrum);
  }

  [[nodiscard]] bool usable() const { return size_ > 0; }

  [[nodiscard]] std::vector<double> periodogram(const WaveGrid& grid, const Eigen::VectorXd& r,
                                                const std::vector<bool>& use) const {
    std::vector<double> binned(size_, 0.0);
    for (std::size_t i = 0; i < station_.size(); ++i)
      if (use[i]) binned[station_[i]] += r[static_cast<Eigen::Index>(i)];
    std::vector<std::complex<double>> spectrum;
    {
      // The plan (its twiddle factors) is made once, not per call.
      const std::lock_guard<std::mutex> lock(mutex_);
      fft_.fwd(spectrum, binned);
    }
    std::vector<double> power(grid.size);
    for (std::size_t k = 0; k < grid.size; ++k) power[k] = std::norm(spectrum[6 + k]);
    return power;
  }

 private:
  std::vector<std::size_t> station_;  // each reading's station index
  std::size_t size_ = 0;              // M; 0: the readings are not on one grid (the direct sum then)
  mutable std::mutex mutex_;
  mutable Eigen::FFT<double> fft_;
};

Variant wave_variant(std::shared_ptr<const std::vector<Tp>> g, double cycles_per_m) {
  Variant v =
      make_lazy_variant(std::move(g), {results::name(results::pitch_wave_sin), results::name(results::pitch_wave_cos)},
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
  const double hi = 1.0 / (pitch_wave_shortest_stations * t.step_m);
  if (hi <= grid.lo) return false;
  grid.size = static_cast<std::size_t>(std::floor((hi - grid.lo) / grid.step)) + 1;
  c.search_size = grid.size;
  auto g = std::make_shared<const std::vector<Tp>>(t.g);
  auto spectrum = std::make_shared<const StationSpectrum>(t.g, grid, t.span_m, t.step_m);
  const double nyquist = 1.0 / (2.0 * t.step_m);
  c.generate = [g, grid, spectrum, nyquist](const Eigen::VectorXd& residual, const std::vector<bool>& use) {
    const std::vector<double> power =
        spectrum->usable() ? spectrum->periodogram(grid, residual, use) : direct_periodogram(*g, grid, residual, use);
    const auto best = static_cast<std::size_t>(std::max_element(power.begin(), power.end()) - power.begin());
    // Placed between grid points: the peak of the parabola through the best point and its neighbours.
    double f = grid.at(best);
    if (best > 0 && best + 1 < grid.size) {
      const double a = power[best - 1], b = power[best], d = power[best + 1];
      const double den = a - 2 * b + d;
      if (den < 0) f += grid.step * std::clamp(0.5 * (a - d) / den, -0.5, 0.5);
    }
    // The strongest line at an end of the band carries the wave a grid step past it (Variant::beyond): a longer wave
    // than 1.5 cycles over the stations is as physical (the base's polynomial takes much of it, and the step past is
    // judged beside the base), a shorter one than 2.5 stations a cycle too while the stations still resolve it (below
    // their Nyquist, 2 stations a cycle); past that the end is a bound of what the data resolve, not an edge.
    std::vector<Variant> out;
    out.push_back(wave_variant(g, f));
    if (best == 0) out.back().beyond.push_back(wave_variant(g, f - grid.step));
    if (best + 1 == grid.size && f + grid.step < nyquist) out.back().beyond.push_back(wave_variant(g, f + grid.step));
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
