// Spindle error motion from a run-out record (error_motion.hpp), as ISO 230-7 defines its values.
#include "models/flatness/error_motion.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>

#include <Eigen/Dense>

#include "dsp/series.hpp"

namespace guideway::models::flatness {

namespace {

constexpr double two_pi = 2.0 * std::numbers::pi;

// The reading at angle a by linear interpolation between the samples around it (angles increasing).
double interpolate(const std::vector<double>& angle, const std::vector<double>& value, double a) {
  const auto hi = std::lower_bound(angle.begin(), angle.end(), a);
  if (hi == angle.begin()) return value.front();
  if (hi == angle.end()) return value.back();
  const auto k = static_cast<std::size_t>(hi - angle.begin());
  const double w = (a - angle[k - 1]) / (angle[k] - angle[k - 1]);
  return value[k - 1] + w * (value[k] - value[k - 1]);
}

}  // namespace

std::size_t whole_revolutions(const std::vector<double>& angle_rad) {
  if (angle_rad.size() < 2) return 0;
  // Each sample stands for the step to the next, so a record of n turns sampled up to one step short
  // of n * 360 deg counts n (and a millionth of a turn of rounding).
  const double span = angle_rad.back() - angle_rad.front();
  const double step = span / static_cast<double>(angle_rad.size() - 1);
  return static_cast<std::size_t>(std::max(0.0, std::floor((span + step) / two_pi + 1e-6)));
}

ErrorMotionResult error_motion(const std::vector<double>& angle_rad, const std::vector<double>& value_m,
                               const std::string& source) {
  if (angle_rad.size() != value_m.size() || angle_rad.empty())
    throw std::invalid_argument(source + ": angles and readings differ in number or are empty");
  for (std::size_t i = 1; i < angle_rad.size(); ++i)
    if (!(angle_rad[i] > angle_rad[i - 1]))
      throw std::invalid_argument(source + ": the angle does not increase at sample " + std::to_string(i + 1));
  ErrorMotionResult r;
  const double a0 = angle_rad.front();
  r.revolutions = whole_revolutions(angle_rad);
  if (r.revolutions < 1)
    throw std::invalid_argument(source +
                                ": less than one whole revolution recorded; ISO 230-7 error motion needs one "
                                "or more (several for the asynchronous part)");
  // Whole revolutions only: samples with angle < a0 + 2 pi n (the end is the next revolution's start).
  const double end = a0 + two_pi * static_cast<double>(r.revolutions) * (1.0 - 1e-12);
  std::vector<double> a, z;
  for (std::size_t i = 0; i < angle_rad.size() && angle_rad[i] < end; ++i) {
    a.push_back(angle_rad[i] - a0);
    z.push_back(value_m[i]);
  }
  r.samples = a.size();
  if (r.samples < 8 * r.revolutions)
    throw std::invalid_argument(source + ": " + std::to_string(r.samples) + " samples in " +
                                std::to_string(r.revolutions) + " revolutions; at least 8 per revolution");
  // The mean and the once-per-revolution term, least squares over every sample.
  const auto n = static_cast<Eigen::Index>(r.samples);
  Eigen::MatrixXd j(n, 3);
  Eigen::VectorXd y(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double phi = a[static_cast<std::size_t>(k)] + a0;
    j.row(k) << 1.0, std::cos(phi), std::sin(phi);
    y(k) = z[static_cast<std::size_t>(k)];
  }
  const Eigen::Vector3d p = j.colPivHouseholderQr().solve(y);
  r.fundamental_m = std::hypot(p(1), p(2));
  r.fundamental_phase_rad = std::atan2(p(2), p(1));
  if (r.fundamental_phase_rad < 0) r.fundamental_phase_rad = std::fmod(r.fundamental_phase_rad + two_pi, two_pi);
  const Eigen::VectorXd res = y - j * p;
  const std::vector<double> e(res.data(), res.data() + n);
  r.total_m = dsp::peak_to_valley(e);
  // One angle grid for every revolution, as fine as the samples (at most 0.1 deg).
  r.points_per_rev = std::clamp<std::size_t>(r.samples / r.revolutions, 8, 3600);
  const std::size_t m = r.points_per_rev;
  // The last revolution's end is interpolated towards its last sample (held beyond it).
  std::vector<double> grid(m * r.revolutions);
  for (std::size_t k = 0; k < grid.size(); ++k)
    grid[k] = interpolate(a, e, two_pi * static_cast<double>(k) / static_cast<double>(m));
  r.synchronous_curve_m.assign(m, 0.0);
  for (std::size_t k = 0; k < grid.size(); ++k) r.synchronous_curve_m[k % m] += grid[k];
  for (double& v : r.synchronous_curve_m) v /= static_cast<double>(r.revolutions);
  r.synchronous_m = dsp::peak_to_valley(r.synchronous_curve_m);
  for (std::size_t i = 0; i < m; ++i) {
    double lo = grid[i], hi = grid[i];
    for (std::size_t rev = 1; rev < r.revolutions; ++rev) {
      lo = std::min(lo, grid[rev * m + i]);
      hi = std::max(hi, grid[rev * m + i]);
    }
    r.asynchronous_m = std::max(r.asynchronous_m, hi - lo);
  }
  return r;
}

namespace {

// The average revolution's harmonics 1..orders at the spindle's angle: c_k with curve(a) ~ sum Re(c_k e^(i k a)).
std::vector<std::complex<double>> harmonics(const std::vector<double>& curve, double zero_rad, std::size_t orders) {
  std::vector<std::complex<double>> c(orders + 1);
  const double m = static_cast<double>(curve.size());
  for (std::size_t k = 1; k <= orders; ++k)
    for (std::size_t j = 0; j < curve.size(); ++j)
      c[k] +=
          curve[j] * std::polar(2.0 / m, -static_cast<double>(k) * (zero_rad + two_pi * static_cast<double>(j) / m));
  return c;
}

}  // namespace

ReversalResult separate_reversal(const ErrorMotionResult& first, double first_zero_rad, const ErrorMotionResult& turned,
                                 double turned_zero_rad, double turned_rad) {
  const std::size_t m = std::min(first.synchronous_curve_m.size(), turned.synchronous_curve_m.size());
  if (m < 8) throw std::invalid_argument("reversal: fewer than 8 points per revolution");
  // Orders below the coarser curve's Nyquist order.
  const std::size_t orders = (m - 1) / 2;
  const auto a = harmonics(first.synchronous_curve_m, first_zero_rad, orders);
  const auto b = harmonics(turned.synchronous_curve_m, turned_zero_rad, orders);
  ReversalResult r;
  r.turned_rad = turned_rad;
  r.points_per_rev = m;
  std::vector<std::complex<double>> s(orders + 1), f(orders + 1);
  bool any = false;
  for (std::size_t k = 1; k <= orders; ++k) {
    const std::complex<double> d = 1.0 - std::polar(1.0, -static_cast<double>(k) * turned_rad);
    if (std::abs(d) >= 1.0) {
      f[k] = (a[k] - b[k]) / d;
      s[k] = a[k] - f[k];
      any = any || k >= 2;
    } else {
      s[k] = 0.5 * (a[k] + b[k]);
      if (k >= 2) r.together_orders.push_back(static_cast<int>(k));
    }
  }
  if (!any)
    throw std::invalid_argument("reversal: a turn of " + std::to_string(turned_rad * 180.0 / std::numbers::pi) +
                                " deg moves no order's form by 60 deg or more: nothing to separate");
  r.spindle_curve_m.assign(m, 0.0);
  r.form_curve_m.assign(m, 0.0);
  for (std::size_t j = 0; j < m; ++j) {
    const double angle = two_pi * static_cast<double>(j) / static_cast<double>(m);
    for (std::size_t k = 1; k <= orders; ++k) {
      const std::complex<double> e = std::polar(1.0, static_cast<double>(k) * angle);
      r.spindle_curve_m[j] += (s[k] * e).real();
      r.form_curve_m[j] += (f[k] * e).real();
    }
  }
  r.spindle_synchronous_m = dsp::peak_to_valley(r.spindle_curve_m);
  r.artifact_form_m = dsp::peak_to_valley(r.form_curve_m);
  return r;
}

}  // namespace guideway::models::flatness
