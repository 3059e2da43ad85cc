// Small statistics of a sampled series (series.hpp), one definition for models, reports and sessions; NaN marks an
// invalid point.
#include "dsp/series.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace guideway::dsp {

double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double e : v) s += e * e;
  return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

double peak_to_valley(const std::vector<double>& v) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double e : v) {
    if (std::isnan(e)) continue;
    lo = std::min(lo, e);
    hi = std::max(hi, e);
  }
  return hi >= lo ? hi - lo : std::numeric_limits<double>::quiet_NaN();
}

std::vector<double> fill_gaps_linear(const std::vector<double>& v) {
  const std::size_t n = v.size();
  const auto first = std::find_if(v.begin(), v.end(), [](double e) { return !std::isnan(e); });
  if (first == v.end()) return v;
  std::vector<double> out = v;
  std::size_t last_valid = static_cast<std::size_t>(first - v.begin());
  std::fill(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(last_valid), v[last_valid]);
  for (std::size_t i = last_valid + 1; i < n; ++i) {
    if (std::isnan(v[i])) continue;
    const double left = v[last_valid], right = v[i];
    for (std::size_t k = last_valid + 1; k < i; ++k) {
      const double w = static_cast<double>(k - last_valid) / static_cast<double>(i - last_valid);
      out[k] = left + w * (right - left);
    }
    last_valid = i;
  }
  std::fill(out.begin() + static_cast<std::ptrdiff_t>(last_valid) + 1, out.end(), v[last_valid]);
  return out;
}

}  // namespace guideway::dsp
