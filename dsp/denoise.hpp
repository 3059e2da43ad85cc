#pragma once
// Wavelet denoising with the universal threshold (Donoho & Johnstone): lambda = sigma * sqrt(2 ln N), with the
// noise level sigma = median(|cD_1|) / 0.6745 from the finest details (or per level, or given), soft or hard
// thresholding of every detail band; the approximation is kept. Batch here; streaming in streaming_wavelet.hpp.

#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "dsp/wavelet.hpp"

namespace guideway::dsp {

enum class ThresholdRule { soft, hard };

[[nodiscard]] ThresholdRule parse_threshold_rule(std::string_view name);  // "soft" | "hard"; throws

struct DenoiseOptions {
  ThresholdRule rule = ThresholdRule::soft;
  // false: one sigma from the finest details for every level; true: sigma_j from each level's own details.
  bool level_dependent = false;
  std::optional<double> sigma;      // known noise standard deviation (replaces the MAD estimate)
  std::optional<double> threshold;  // fixed lambda for every detail band (replaces sigma and the rule's N)
};

struct DenoiseResult {
  std::vector<double> signal;      // denoised signal, same length as the input
  std::vector<double> thresholds;  // lambda per band in PyWavelets' order; thresholds[0] (approximation) = 0
  double sigma = 0.0;              // noise level used (finest level's when level_dependent)
};

// median(|d|) / 0.6745: the robust noise estimate from detail coefficients (throws on empty input or NaN).
[[nodiscard]] double mad_sigma(std::span<const double> details);
// sigma * sqrt(2 ln n) (0 for n <= 1).
[[nodiscard]] double universal_threshold(double sigma, std::size_t n);
// Soft: sign(v) max(|v| - t, 0). Hard: v if |v| >= t, else 0 (PyWavelets' pywt.threshold semantics).
[[nodiscard]] inline double apply_threshold(double v, double t, ThresholdRule rule) {
  const double m = v < 0 ? -v : v;
  if (m < t) return 0.0;
  if (rule == ThresholdRule::hard) return v;
  return v < 0 ? -(m - t) : m - t;
}

// Decompose (wavedec), threshold the details, reconstruct (waverec, trimmed to the input length).
// Throws std::invalid_argument on an empty signal or a non-finite sample.
[[nodiscard]] DenoiseResult denoise(std::span<const double> x, const Wavelet& wavelet, Mode mode, int level,
                                    const DenoiseOptions& options = {});

}  // namespace guideway::dsp
