// A pitch wave in the geometry a traverse's passes share (shared_wave.hpp): a line of the station means, against
// their own spectrum.
#include "models/explain/shared_wave.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <complex>
#include <numbers>

#include <Eigen/Dense>
#include <unsupported/Eigen/FFT>

#include "models/explain/effects/traverse_terms.hpp"

namespace guideway::models::explain {

namespace {

// ln of a periodogram scatters about ln of its spectrum less Euler's gamma (the mean log of an exponential).
constexpr double euler_gamma = 0.5772156649015329;
// Above the fitted spectrum by more than this (in ln), a line is left out of the spectrum's fit: an exponential's
// 1-in-1000 tail (e^(2.5 - gamma) = 6.8 times the spectrum), a line's own power or its leakage.
constexpr double spectrum_outlier_ln = 2.5;
constexpr int spectrum_degree = 3;  // the spectrum: a power law bent by a square and a cube of ln k
constexpr std::size_t spectrum_fewest_lines = 8;  // fewer lines left for its fit than this: every line

// The geometry's spectrum: ln of the periodogram at k cycles against a cubic in ln k, least squares over the lines
// in use; evaluated at any k (cycles over the stations) as a station mean's variance there.
class SmoothSpectrum {
 public:
  SmoothSpectrum(const std::vector<double>& k, const std::vector<double>& log_power, const std::vector<bool>& use) {
    centre_ = (std::log(k.front()) + std::log(k.back())) / 2;
    half_ = std::max((std::log(k.back()) - std::log(k.front())) / 2, 1e-9);
    std::vector<Eigen::Index> rows;
    for (std::size_t j = 0; j < k.size(); ++j)
      if (use[j]) rows.push_back(static_cast<Eigen::Index>(j));
    if (rows.size() < spectrum_fewest_lines) {
      rows.clear();
      for (std::size_t j = 0; j < k.size(); ++j) rows.push_back(static_cast<Eigen::Index>(j));
    }
    Eigen::MatrixXd a(static_cast<Eigen::Index>(rows.size()), spectrum_degree + 1);
    Eigen::VectorXd b(a.rows());
    for (Eigen::Index r = 0; r < a.rows(); ++r) {
      const auto j = static_cast<std::size_t>(rows[static_cast<std::size_t>(r)]);
      a.row(r) = powers(k[j]).transpose();
      b[r] = log_power[j];
    }
    coef_ = a.colPivHouseholderQr().solve(b);
  }
  [[nodiscard]] double at(double k) const { return std::exp(powers(k).dot(coef_) + euler_gamma); }

 private:
  [[nodiscard]] Eigen::VectorXd powers(double k) const {
    Eigen::VectorXd p(spectrum_degree + 1);
    const double u = (std::log(k) - centre_) / half_;
    p[0] = 1.0;
    for (int d = 1; d <= spectrum_degree; ++d) p[d] = p[d - 1] * u;
    return p;
  }
  double centre_ = 0.0, half_ = 1.0;
  Eigen::VectorXd coef_;
};

// The periodogram of v at c cycles over its stations, |sum_s v_s exp(-2 pi i c s / S)|^2 / S (its mean is a station
// value's variance where v is white).
double periodogram_at(const Eigen::VectorXd& v, double c) {
  const auto stations = static_cast<double>(v.size());
  const std::complex<double> turn = std::polar(1.0, -2 * std::numbers::pi * c / stations);
  std::complex<double> z = 1.0, sum = 0.0;
  for (Eigen::Index s = 0; s < v.size(); ++s, z *= turn) sum += v[s] * z;
  return std::norm(sum) / stations;
}

// The periodogram's highest point within a bin of k: an eighth of a bin apart, then the parabola through the
// highest and its neighbours.
double placed_line(const Eigen::VectorXd& v, double k) {
  constexpr int points = 17;
  std::vector<double> p(points);
  for (int j = 0; j < points; ++j) p[static_cast<std::size_t>(j)] = periodogram_at(v, k - 1.0 + j / 8.0);
  const auto top = static_cast<std::size_t>(std::max_element(p.begin(), p.end()) - p.begin());
  double c = k - 1.0 + static_cast<double>(top) / 8.0;
  if (top > 0 && top + 1 < p.size()) {
    const double den = p[top - 1] - 2 * p[top] + p[top + 1];
    if (den < 0) c += std::clamp(0.5 * (p[top - 1] - p[top + 1]) / den, -0.5, 0.5) / 8.0;
  }
  return c;
}

}  // namespace

SharedWave shared_wave(const std::vector<double>& mean_urad, double x0_m, double step_m, double alpha) {
  SharedWave out;
  const auto stations = static_cast<Eigen::Index>(mean_urad.size());
  const auto first = static_cast<std::size_t>(shared_wave_first_cycles);
  const auto last = static_cast<std::size_t>(std::floor(static_cast<double>(stations) / effects::pitch_wave_shortest_stations));
  if (!(step_m > 0) || last < first || last - first + 1 < shared_wave_min_lines) return out;
  // The geometry less a constant and a line in x: a set-up's tilt and a flat's curvature, whose leakage is no line.
  const Eigen::Map<const Eigen::VectorXd> m(mean_urad.data(), stations);
  Eigen::MatrixXd design(stations, 4);
  for (Eigen::Index s = 0; s < stations; ++s) {
    design(s, 0) = 1.0;
    design(s, 1) = (static_cast<double>(s) + 0.5) / static_cast<double>(stations) - 0.5;
  }
  const auto trend = design.leftCols(2);
  const Eigen::VectorXd v = m - trend * trend.colPivHouseholderQr().solve(m);
  // Its periodogram at whole cycles over the stations, 3 .. stations / 2.5 (one FFT).
  std::vector<std::complex<double>> in(v.data(), v.data() + stations), spectrum;
  Eigen::FFT<double> fft;
  fft.fwd(spectrum, in);
  std::vector<double> k, power, log_power;
  for (std::size_t c = first; c <= last; ++c) {
    k.push_back(static_cast<double>(c));
    power.push_back(std::norm(spectrum[c]) / static_cast<double>(stations));
    log_power.push_back(std::log(std::max(power.back(), 1e-300)));
  }
  // The spectrum, fitted again without the lines far above it, then without the line standing highest above it
  // (inside the band: a line at an end has no neighbour past it) and its neighbours, its leakage.
  std::vector<bool> use(k.size(), true);
  SmoothSpectrum fit(k, log_power, use);
  for (std::size_t j = 0; j < k.size(); ++j)
    use[j] = log_power[j] - std::log(fit.at(k[j])) + euler_gamma < spectrum_outlier_ln;
  fit = SmoothSpectrum(k, log_power, use);
  std::size_t best = 1;
  for (std::size_t j = 1; j + 1 < k.size(); ++j)
    if (power[j] / fit.at(k[j]) > power[best] / fit.at(k[best])) best = j;
  for (std::size_t j = 0; j < k.size(); ++j)
    if (std::abs(k[j] - k[best]) <= 1.0) use[j] = false;
  fit = SmoothSpectrum(k, log_power, use);
  out.cycles = placed_line(v, k[best]);
  out.period_m = static_cast<double>(stations) * step_m / out.cycles;
  out.spectrum = fit.at(out.cycles);
  const double line_power = periodogram_at(v, out.cycles);
  out.ratio = line_power / out.spectrum;
  // Its neighbours: the lines 2 .. W + 1 bins away each side, W a quarter of its cycles (4 at least); their median
  // over ln 2 is an exponential's mean. The smooth spectrum misses where the figure rises steeply at the band's low
  // end (two 9,230-station scans: a line 1,100 times "above" it at 4 cycles, 2 to 8 times its neighbours).
  const double reach = std::max(4.0, std::floor(k[best] / 4)) + 1;
  std::vector<double> near;
  for (std::size_t j = 0; j < k.size(); ++j)
    if (std::abs(k[j] - k[best]) > 1.0 && std::abs(k[j] - k[best]) <= reach) near.push_back(power[j]);
  std::nth_element(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(near.size() / 2), near.end());
  out.local_ratio = line_power / (near[near.size() / 2] / std::numbers::ln2);
  out.lines = 4 * k.size();
  out.needed = std::log(static_cast<double>(out.lines) / alpha);
  out.found = out.ratio > out.needed && out.local_ratio > out.needed;
  out.judged = true;
  // Its size: a sine at the stations' mid-points fitted to the geometry beside the constant and the line, the
  // spectrum there as the station means' noise (locally white: a line's neighbours are what it cannot be told from).
  for (Eigen::Index s = 0; s < stations; ++s) {
    const double th = 2 * std::numbers::pi * (x0_m + (static_cast<double>(s) + 0.5) * step_m) / out.period_m;
    design(s, 2) = std::sin(th) * effects::urad_per_arcsec;
    design(s, 3) = std::cos(th) * effects::urad_per_arcsec;
  }
  const Eigen::VectorXd coef = design.colPivHouseholderQr().solve(m);
  const Eigen::MatrixXd cov = out.spectrum * (design.transpose() * design).inverse();
  out.sin_arcsec = coef[2];
  out.cos_arcsec = coef[3];
  out.var_sin = cov(2, 2);
  out.var_cos = cov(3, 3);
  out.cov_sin_cos = cov(2, 3);
  return out;
}

}  // namespace guideway::models::explain
