#include "models/dbb/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace guideway::models::dbb {

namespace {

constexpr double pi = std::numbers::pi;

double sign_outside_dead_zone(double x) { return x > 1e-9 ? 1.0 : (x < -1e-9 ? -1.0 : 0.0); }

}  // namespace

SampleGeometry circle_geometry(double radius_m, double height_m, int dir, double feed_m_per_s, double zeta_rad) {
  SampleGeometry g;
  g.zeta_rad = zeta_rad;
  g.c = std::cos(zeta_rad);
  g.s = std::sin(zeta_rad);
  g.radius_m = radius_m;
  g.height_m = height_m;
  const double l0 = std::sqrt(radius_m * radius_m + height_m * height_m);
  g.lambda = radius_m / l0;
  g.h_over_l0 = height_m / l0;
  g.dir = dir;
  g.feed_m_per_s = feed_m_per_s;
  g.omega_rad_per_s = feed_m_per_s / radius_m;
  g.sgn_a = velocity_sign_a(g.dir, g.s);
  g.sgn_b = velocity_sign_b(g.dir, g.c);
  g.since_a_s = angle_since_reversal_rad(zeta_rad, 0.0, g.dir) / g.omega_rad_per_s;
  g.since_b_s = angle_since_reversal_rad(zeta_rad, pi / 2, g.dir) / g.omega_rad_per_s;
  return g;
}

void fill_sample_geometry(const formats::DbbRun& run, std::size_t run_index, std::size_t i, SampleGeometry& out) {
  out = circle_geometry(run.radius_m, run.height_m, run.dir(), run.feed_m_per_s, run.angle_rad[i]);
  out.run = run_index;
  out.a_m = run.center_a_m + run.radius_m * out.c;
  out.b_m = run.center_b_m + run.radius_m * out.s;
  out.dL_um = run.dL_m[i] * 1e6;
}

double velocity_sign_a(double dir, double sin_zeta) { return -dir * sign_outside_dead_zone(sin_zeta); }

double velocity_sign_b(double dir, double cos_zeta) { return dir * sign_outside_dead_zone(cos_zeta); }

double angle_since_reversal_rad(double zeta_rad, double phase_rad, double dir) {
  const double q = (zeta_rad - phase_rad) / pi;
  const double last = dir > 0 ? std::floor(q) : std::ceil(q);
  return std::abs(zeta_rad - phase_rad - last * pi);
}

double reversal_spike_decay(double t_s, double tau_s) {
  return (t_s < 0 || t_s > 8 * tau_s) ? 0.0 : std::exp(-t_s / tau_s);
}

double rise_since_reversal_m(double radius_m, double angle_since_reversal_rad) {
  const double half = std::sin(0.5 * angle_since_reversal_rad);
  return 2 * radius_m * half * half;
}

double deadband_lost_motion(double velocity_sign, double rise_m, double backlash_m) {
  const double taken_up = backlash_m > 0 ? std::clamp(rise_m / backlash_m - 0.5, -0.5, 0.5) : 0.5;
  return -velocity_sign * taken_up;
}

}  // namespace guideway::models::dbb
