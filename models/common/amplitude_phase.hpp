#pragma once
// A line fitted as its sine and cosine parts, s sin(theta) + c cos(theta) = A sin(theta + phi): its amplitude
// A = hypot(s, c) and phase phi = atan2(c, s), each with its first-order standard uncertainty from the parts'
// covariance (the parts of a line fitted beside other terms correlate: their u's do not simply add in
// quadrature). Pure; thread safe.

namespace guideway::models {

struct AmplitudePhase {
  double amplitude = 0.0;
  double u_amplitude = 0.0;  // NaN when the amplitude is 0 (the phase is then undefined too)
  double phase_rad = 0.0;    // in (-pi, pi]
  double u_phase_rad = 0.0;
};

// var_s, var_c: the parts' variances; cov_sc: their covariance.
AmplitudePhase amplitude_phase(double s, double c, double var_s, double var_c, double cov_sc);

}  // namespace guideway::models
