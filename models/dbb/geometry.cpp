// The per-sample geometry of a DBB circular test (geometry.hpp) that identification and EXPLAIN both see.
#include "models/dbb/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "models/dbb/fast_sincos.hpp"

namespace guideway::models::dbb {

namespace {

constexpr double pi = std::numbers::pi;

double sign_outside_dead_zone(double x) { return x > 1e-9 ? 1.0 : (x < -1e-9 ? -1.0 : 0.0); }

// The number k of an axis' last reversal, at zeta = phase + k pi, on a circle traced in direction dir.
double last_reversal(double zeta_rad, double phase_rad, double dir) {
  const double q = (zeta_rad - phase_rad) / pi;
  return dir > 0 ? std::floor(q) : std::ceil(q);
}

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
  out.center_a_m = run.center_a_m;
  out.center_b_m = run.center_b_m;
  out.dL_um = run.dL_m[i] * 1e6;
}

double velocity_sign_a(double dir, double sin_zeta) { return -dir * sign_outside_dead_zone(sin_zeta); }

double velocity_sign_b(double dir, double cos_zeta) { return dir * sign_outside_dead_zone(cos_zeta); }

double angle_since_reversal_rad(double zeta_rad, double phase_rad, double dir) {
  return std::abs(zeta_rad - phase_rad - last_reversal(zeta_rad, phase_rad, dir) * pi);
}

double reversal_spike_decay(double t_s, double tau_s) {
  return (t_s < 0 || t_s > spike_extent_decays * tau_s) ? 0.0 : std::exp(-t_s / tau_s);
}

double rise_since_reversal_m(double radius_m, double angle_since_reversal_rad) {
  const double half = std::sin(0.5 * angle_since_reversal_rad);
  return 2 * radius_m * half * half;
}

std::vector<double> drive_delays_s(const std::vector<formats::DbbRun>& runs) {
  const bool encoders = std::all_of(runs.begin(), runs.end(), [](const formats::DbbRun& r) {
    const auto it = r.metadata.find("angle_source");
    return it != r.metadata.end() && it->second == "encoders";
  });
  if (encoders) return {0.0};
  return {0.0, 5e-3, 10e-3, 15e-3, 20e-3, 25e-3, 30e-3, 40e-3, 50e-3, 60e-3, 80e-3, 100e-3};
}

namespace {
// The angle the drives are at when they follow the command delay_s late.
double delayed_angle_rad(const SampleGeometry& p, double delay_s) {
  return p.zeta_rad - p.dir * p.omega_rad_per_s * delay_s;
}
}  // namespace

std::array<double, 2> drive_position(const SampleGeometry& p, double delay_s) {
  const double z = delayed_angle_rad(p, delay_s);
  double s = 0, c = 0;
  fast_sincos(z, s, c);
  return {p.center_a_m + p.radius_m * c, p.center_b_m + p.radius_m * s};
}

double drive_rise_m(const SampleGeometry& p, double delay_s, double phase_rad) {
  const double z = delayed_angle_rad(p, delay_s);
  return rise_since_reversal_m(p.radius_m, angle_since_reversal_rad(z, phase_rad, p.dir));
}

// After its k-th reversal (a at cos z = (-1)^k, b at sin z = (-1)^k) an axis moves back towards the centre, whichever
// way the circle is traced: so -1 after an even k. Exactly at a reversal that is the direction it is about to take,
// and its rise is 0: the deadband then holds it on the approach's side.
double drive_direction(const SampleGeometry& p, double delay_s, double phase_rad) {
  const double z = delayed_angle_rad(p, delay_s);
  return std::fmod(std::abs(last_reversal(z, phase_rad, p.dir)), 2.0) == 1.0 ? 1.0 : -1.0;
}

void add_drive_sample(DriveTrack& t, const SampleGeometry& p) {
  for (const double phase : {0.0, pi / 2}) {
    const auto packed = static_cast<float>(drive_rise_m(p, t.delay_s, phase));
    (phase == 0.0 ? t.a : t.b).push_back(std::copysign(packed, static_cast<float>(drive_direction(p, t.delay_s, phase))));
  }
}

}  // namespace guideway::models::dbb
