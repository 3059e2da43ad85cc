// Wavelet denoising (denoise.hpp): the universal threshold from the finest details' MAD, soft or hard, per level or
// given.
#include "dsp/denoise.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace guideway::dsp {

ThresholdRule parse_threshold_rule(std::string_view name) {
  if (name == "soft") return ThresholdRule::soft;
  if (name == "hard") return ThresholdRule::hard;
  throw std::invalid_argument("unknown threshold rule '" + std::string(name) + "' (known: soft, hard)");
}

double mad_sigma(std::span<const double> details) {
  if (details.empty()) throw std::invalid_argument("noise estimate: no detail coefficients");
  std::vector<double> m(details.size());
  for (std::size_t i = 0; i < details.size(); ++i) {
    if (!std::isfinite(details[i])) throw std::invalid_argument("noise estimate: non-finite detail coefficient");
    m[i] = std::fabs(details[i]);
  }
  const std::size_t mid = m.size() / 2;
  std::nth_element(m.begin(), m.begin() + static_cast<std::ptrdiff_t>(mid), m.end());
  double med = m[mid];
  if (m.size() % 2 == 0) {
    const double lower = *std::max_element(m.begin(), m.begin() + static_cast<std::ptrdiff_t>(mid));
    med = 0.5 * (lower + med);
  }
  return med / 0.6745;
}

double universal_threshold(double sigma, std::size_t n) {
  if (n <= 1) return 0.0;
  return sigma * std::sqrt(2.0 * std::log(static_cast<double>(n)));
}

DenoiseResult denoise(std::span<const double> x, const Wavelet& wavelet, Mode mode, int level,
                      const DenoiseOptions& options) {
  if (x.empty()) throw std::invalid_argument("denoise: empty signal");
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i])) {
      throw std::invalid_argument("denoise: sample " + std::to_string(i) + " is not a finite number");
    }
  }
  if (options.sigma && !(*options.sigma >= 0.0)) throw std::invalid_argument("denoise: sigma must be >= 0");
  if (options.threshold && !(*options.threshold >= 0.0)) throw std::invalid_argument("denoise: threshold must be >= 0");
  Coefficients c = wavedec(x, wavelet, mode, level);
  DenoiseResult out;
  out.thresholds.assign(c.size(), 0.0);
  if (c.size() > 1) {
    const double sigma_fine = options.sigma ? *options.sigma : mad_sigma(c.back());
    out.sigma = sigma_fine;
    for (std::size_t b = 1; b < c.size(); ++b) {
      double t = 0.0;
      if (options.threshold) {
        t = *options.threshold;
      } else {
        const double s = (options.level_dependent && !options.sigma) ? mad_sigma(c[b]) : sigma_fine;
        t = universal_threshold(s, x.size());
      }
      out.thresholds[b] = t;
      for (double& v : c[b]) v = apply_threshold(v, t, options.rule);
    }
  }
  out.signal = waverec(c, wavelet, mode);
  out.signal.resize(x.size());
  return out;
}

}  // namespace guideway::dsp
