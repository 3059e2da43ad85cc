#pragma once
// Correlation of signals (Mu et al. 2012, Eqs. 6, 19, 20): Pearson coefficient, the paper's comparison of a
// measured signal and of its wavelet low-frequency part with simulated error components, normalised
// cross-correlation over lags, and a sliding-window Pearson coefficient for streams.
// Degenerate input is refused with CorrelationError (never a NaN result).

#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "dsp/wavelet.hpp"

namespace guideway::dsp {

// Input that has no correlation coefficient: unequal lengths, fewer than 2 samples, a non-finite value, or a
// constant signal (zero variance). The message names the argument and the reason.
class CorrelationError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// Eq. 6: sum((x - mean x)(y - mean y)) / sqrt(sum((x - mean x)^2) sum((y - mean y)^2)), in [-1, 1].
[[nodiscard]] double pearson(std::span<const double> x, std::span<const double> y);

// Eqs. 19 and 20: the coefficient of the measured signal x with each simulated component y_m, before
// (gamma_x_y) and after (gamma_x1_y) the wavelet transform, where x1 = the approximation component A_j of x at
// `approx_level` j (Mu use db1 and a1). Eq. 20 is evaluated as a Pearson coefficient of x1 (centred on its own
// mean; the paper's printed x-bar in Eq. 20 is read as x1-bar).
struct WaveletCorrelation {
  std::vector<double> gamma_x_y;   // Eq. 19, one per component
  std::vector<double> gamma_x1_y;  // Eq. 20, one per component
  std::vector<double> x1;          // the low-frequency part used
};
[[nodiscard]] WaveletCorrelation wavelet_correlation(std::span<const double> x,
                                                     const std::vector<std::span<const double>>& components,
                                                     const Wavelet& wavelet, Mode mode, int approx_level);

// Normalised cross-correlation of equal-length x and y for lags k in [-max_lag, max_lag]:
//   r(k) = sum_i (x_i - mean x)(y_(i+k) - mean y) / sqrt(sum (x - mean x)^2 * sum (y - mean y)^2),
// summing over the overlap (r(0) is the Pearson coefficient; a positive peak lag means y lags behind x).
// max_lag is clamped to n - 1. The peak is the largest r (the first in lag order on a tie).
struct CrossCorrelation {
  std::int64_t max_lag = 0;
  std::vector<double> values;  // values[k + max_lag] = r(k)
  std::int64_t peak_lag = 0;
  double peak_value = 0.0;
};
[[nodiscard]] CrossCorrelation cross_correlation(std::span<const double> x, std::span<const double> y,
                                                 std::size_t max_lag);

// Pearson coefficient over the last `window` pairs of two synchronous streams. O(1) per pair, no allocation
// after construction; sums are recomputed from the window every `window` pairs so rounding does not drift.
// Single-threaded.
class SlidingCorrelation {
 public:
  explicit SlidingCorrelation(std::size_t window);  // window >= 2

  // Throws CorrelationError for a non-finite value (the pair is not added).
  void push(double x, double y);
  void push(std::span<const double> x, std::span<const double> y);  // equal lengths
  void reset();

  [[nodiscard]] std::size_t window() const { return window_; }
  [[nodiscard]] std::size_t size() const { return count_ < window_ ? count_ : window_; }
  // True when value() would succeed (>= 2 pairs, neither signal constant over the window).
  [[nodiscard]] bool ready() const;
  // The coefficient over the current window; throws CorrelationError saying why when !ready().
  [[nodiscard]] double value() const;

 private:
  void recompute();

  std::size_t window_;
  std::vector<double> xs_;
  std::vector<double> ys_;
  std::uint64_t count_ = 0;
  std::size_t since_recompute_ = 0;
  double ref_x_ = 0.0, ref_y_ = 0.0;  // shift for conditioning
  double sx_ = 0.0, sy_ = 0.0, sxx_ = 0.0, syy_ = 0.0, sxy_ = 0.0;
};

}  // namespace guideway::dsp
