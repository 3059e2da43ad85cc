// Correlation of signals (correlation.hpp): Pearson's coefficient and Mu's comparisons of a measured signal with
// simulated error components.
#include "dsp/correlation.hpp"

#include <cmath>

namespace guideway::dsp {

namespace {

void check_pair(std::span<const double> x, std::span<const double> y, const char* what) {
  if (x.size() != y.size()) {
    throw CorrelationError(std::string(what) + ": signals of unequal length (" + std::to_string(x.size()) + " and " +
                           std::to_string(y.size()) + " samples)");
  }
  if (x.size() < 2)
    throw CorrelationError(std::string(what) + ": need at least 2 samples, got " + std::to_string(x.size()));
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i]))
      throw CorrelationError(std::string(what) + ": x[" + std::to_string(i) + "] is not a finite number");
    if (!std::isfinite(y[i]))
      throw CorrelationError(std::string(what) + ": y[" + std::to_string(i) + "] is not a finite number");
  }
}

// Mean with one correction pass, accurate to a few ulps of the data even for long, offset signals.
double mean(std::span<const double> v) {
  const auto n = static_cast<double>(v.size());
  double s = 0.0;
  for (double a : v) s += a;
  const double m = s / n;
  double r = 0.0;
  for (double a : v) r += a - m;
  return m + r / n;
}

// Sum of squared deviations; throws when the signal is constant.
double centred_energy(std::span<const double> v, double m, const char* what, const char* name) {
  bool all_equal = true;
  for (double a : v) all_equal = all_equal && a == v[0];
  if (all_equal) throw CorrelationError(std::string(what) + ": signal " + name + " is constant (zero variance)");
  double s = 0.0;
  double peak = 0.0;
  for (double a : v) {
    s += (a - m) * (a - m);
    peak = std::fmax(peak, std::fabs(a));
  }
  // Deviations at the level of rounding of the mean are a constant signal, not a shape to correlate.
  const double floor =
      static_cast<double>(v.size()) * (8.0 * 2.220446049250313e-16 * peak) * (8.0 * 2.220446049250313e-16 * peak);
  if (!(s > floor)) throw CorrelationError(std::string(what) + ": signal " + name + " is constant (zero variance)");
  return s;
}

double clamp_unit(double r) { return r > 1.0 ? 1.0 : (r < -1.0 ? -1.0 : r); }

}  // namespace

double pearson(std::span<const double> x, std::span<const double> y) {
  check_pair(x, y, "pearson");
  const double mx = mean(x);
  const double my = mean(y);
  const double sxx = centred_energy(x, mx, "pearson", "x");
  const double syy = centred_energy(y, my, "pearson", "y");
  double sxy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) sxy += (x[i] - mx) * (y[i] - my);
  return clamp_unit(sxy / (std::sqrt(sxx) * std::sqrt(syy)));
}

WaveletCorrelation wavelet_correlation(std::span<const double> x,
                                       const std::vector<std::span<const double>>& components, const Wavelet& wavelet,
                                       Mode mode, int approx_level) {
  if (approx_level < 1) throw CorrelationError("wavelet correlation: approximation level must be >= 1");
  if (components.empty()) throw CorrelationError("wavelet correlation: no simulated components given");
  for (std::size_t m = 0; m < components.size(); ++m) {
    check_pair(x, components[m], ("wavelet correlation, component " + std::to_string(m + 1)).c_str());
  }
  WaveletCorrelation out;
  WaveletPlan plan(wavelet, mode, x.size(), approx_level);
  std::vector<double> packed(plan.coeff_count());
  plan.decompose(x, packed);
  out.x1.resize(x.size());
  plan.component(packed, 0, out.x1);
  for (const auto& y : components) {
    out.gamma_x_y.push_back(pearson(x, y));
    out.gamma_x1_y.push_back(pearson(out.x1, y));
  }
  return out;
}

CrossCorrelation cross_correlation(std::span<const double> x, std::span<const double> y, std::size_t max_lag) {
  check_pair(x, y, "cross-correlation");
  const std::size_t n = x.size();
  if (max_lag > n - 1) max_lag = n - 1;
  const double mx = mean(x);
  const double my = mean(y);
  const double norm = std::sqrt(centred_energy(x, mx, "cross-correlation", "x")) *
                      std::sqrt(centred_energy(y, my, "cross-correlation", "y"));
  std::vector<double> xc(n);
  std::vector<double> yc(n);
  for (std::size_t i = 0; i < n; ++i) {
    xc[i] = x[i] - mx;
    yc[i] = y[i] - my;
  }
  CrossCorrelation out;
  out.max_lag = static_cast<std::int64_t>(max_lag);
  out.values.resize(2 * max_lag + 1);
  for (std::int64_t k = -out.max_lag; k <= out.max_lag; ++k) {
    // sum over i with 0 <= i < n and 0 <= i + k < n
    const std::size_t i0 = k < 0 ? static_cast<std::size_t>(-k) : 0;
    const std::size_t i1 = k < 0 ? n : n - static_cast<std::size_t>(k);
    double s = 0.0;
    for (std::size_t i = i0; i < i1; ++i) s += xc[i] * yc[static_cast<std::size_t>(static_cast<std::int64_t>(i) + k)];
    const double r = clamp_unit(s / norm);
    out.values[static_cast<std::size_t>(k + out.max_lag)] = r;
    if (k == -out.max_lag || r > out.peak_value) {
      out.peak_value = r;
      out.peak_lag = k;
    }
  }
  return out;
}

SlidingCorrelation::SlidingCorrelation(std::size_t window) : window_(window) {
  if (window < 2) throw CorrelationError("sliding correlation: window must hold at least 2 pairs");
  xs_.assign(window, 0.0);
  ys_.assign(window, 0.0);
}

void SlidingCorrelation::reset() {
  count_ = 0;
  since_recompute_ = 0;
  ref_x_ = ref_y_ = 0.0;
  sx_ = sy_ = sxx_ = syy_ = sxy_ = 0.0;
}

void SlidingCorrelation::recompute() {
  const std::size_t n = size();
  // Shift by the newest pair: keeps the sums of squares well conditioned for signals with a large offset.
  const std::size_t newest = static_cast<std::size_t>((count_ - 1) % window_);
  ref_x_ = xs_[newest];
  ref_y_ = ys_[newest];
  sx_ = sy_ = sxx_ = syy_ = sxy_ = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double a = xs_[i] - ref_x_;
    const double b = ys_[i] - ref_y_;
    sx_ += a;
    sy_ += b;
    sxx_ += a * a;
    syy_ += b * b;
    sxy_ += a * b;
  }
  since_recompute_ = 0;
}

void SlidingCorrelation::push(double x, double y) {
  if (!std::isfinite(x)) throw CorrelationError("sliding correlation: x is not a finite number");
  if (!std::isfinite(y)) throw CorrelationError("sliding correlation: y is not a finite number");
  const std::size_t slot = static_cast<std::size_t>(count_ % window_);
  if (count_ >= window_) {
    const double a = xs_[slot] - ref_x_;
    const double b = ys_[slot] - ref_y_;
    sx_ -= a;
    sy_ -= b;
    sxx_ -= a * a;
    syy_ -= b * b;
    sxy_ -= a * b;
  }
  xs_[slot] = x;
  ys_[slot] = y;
  ++count_;
  if (count_ == 1) {
    recompute();
    return;
  }
  const double a = x - ref_x_;
  const double b = y - ref_y_;
  sx_ += a;
  sy_ += b;
  sxx_ += a * a;
  syy_ += b * b;
  sxy_ += a * b;
  if (++since_recompute_ >= window_) recompute();
}

void SlidingCorrelation::push(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size()) {
    throw CorrelationError("sliding correlation: chunks of unequal length (" + std::to_string(x.size()) + " and " +
                           std::to_string(y.size()) + ")");
  }
  for (std::size_t i = 0; i < x.size(); ++i) push(x[i], y[i]);
}

bool SlidingCorrelation::ready() const {
  if (size() < 2) return false;
  const double n = static_cast<double>(size());
  const double vx = sxx_ - sx_ * sx_ / n;
  const double vy = syy_ - sy_ * sy_ / n;
  // Relative tolerance: variance below rounding of the sums counts as zero.
  const double eps = 64.0 * 2.220446049250313e-16;
  return vx > eps * sxx_ && vy > eps * syy_ && vx > 0.0 && vy > 0.0;
}

double SlidingCorrelation::value() const {
  if (size() < 2) throw CorrelationError("sliding correlation: fewer than 2 pairs in the window");
  const double n = static_cast<double>(size());
  const double vx = sxx_ - sx_ * sx_ / n;
  const double vy = syy_ - sy_ * sy_ / n;
  const double eps = 64.0 * 2.220446049250313e-16;
  if (!(vx > eps * sxx_ && vx > 0.0)) throw CorrelationError("sliding correlation: x is constant over the window");
  if (!(vy > eps * syy_ && vy > 0.0)) throw CorrelationError("sliding correlation: y is constant over the window");
  const double r = (sxy_ - sx_ * sy_ / n) / (std::sqrt(vx) * std::sqrt(vy));
  return clamp_unit(r);
}

}  // namespace guideway::dsp
