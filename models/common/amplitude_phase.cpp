// A sine and cosine pair as amplitude and phase (amplitude_phase.hpp), each with its first-order standard uncertainty.
#include "models/common/amplitude_phase.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace guideway::models {

AmplitudePhase amplitude_phase(double s, double c, double var_s, double var_c, double cov_sc) {
  AmplitudePhase out;
  out.amplitude = std::hypot(s, c);
  out.phase_rad = std::atan2(c, s);
  const double a = out.amplitude;
  if (!(a > 0)) {
    out.u_amplitude = out.u_phase_rad = std::numeric_limits<double>::quiet_NaN();
    return out;
  }
  // Gradients: dA/d(s, c) = (s, c) / A, dphi/d(s, c) = (-c, s) / A^2.
  const auto propagated = [&](double gs, double gc) {
    return std::sqrt(std::max(0.0, gs * gs * var_s + gc * gc * var_c + 2 * gs * gc * cov_sc));
  };
  out.u_amplitude = propagated(s / a, c / a);
  out.u_phase_rad = propagated(-c / (a * a), s / (a * a));
  return out;
}

}  // namespace guideway::models
