#pragma once
// The geometry of a DBB circular test per sample, as every DBB model sees it (identification and
// EXPLAIN): where the commanded point is, how much of an axis' error the bar reads there, which way
// each axis moves and how long since it last reversed, and the lost motion of a backlash deadband.
// Conventions (axes, signs, lambda): docs/conventions.md. Pure functions; thread safe.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "formats/dbb_run.hpp"

namespace guideway::models::dbb {

struct SampleGeometry {
  std::size_t run = 0;  // index of the sample's run in the list being modelled
  double zeta_rad = 0;  // commanded angle, from +a towards +b
  double c = 0, s = 0;  // cos and sin of zeta: dL = lambda (da c + db s) + h_over_l0 dn to first order
  double radius_m = 0, height_m = 0;
  double lambda = 0;     // r / L0: the part of an in-plane error the tilted bar reads
  double h_over_l0 = 0;  // h / L0: the part of an error along the plane normal it reads
  double dir = 1;        // +1 ccw (zeta increasing), -1 cw
  double feed_m_per_s = 0, omega_rad_per_s = 0;
  double sgn_a = 0, sgn_b = 0;            // signs of the axes' velocities, 0 at a reversal
  double since_a_s = 0, since_b_s = 0;    // time since the last reversal of a / b (spikes decay from it)
  double a_m = 0, b_m = 0;                // machine coordinates of the commanded point (cyclic error phase)
  double center_a_m = 0, center_b_m = 0;  // the circle's centre, where a lagging drive's position is reckoned from
  double dL_um = 0;                       // the bar's reading
};

// The geometry at commanded angle zeta of a circle of radius r and socket height h traced in direction
// dir (+1 ccw, -1 cw) at the given feed; run index, position and reading are left 0.
SampleGeometry circle_geometry(double radius_m, double height_m, int dir, double feed_m_per_s, double zeta_rad);

// Sample i of `run`, which is run number run_index of the list being modelled. Fills `out` in place:
// the models keep one larger struct per sample that starts with this one.
void fill_sample_geometry(const formats::DbbRun& run, std::size_t run_index, std::size_t i, SampleGeometry& out);

// Sign of da/dt (from sin zeta) and db/dt (from cos zeta) on a circle traced in direction dir:
// da/dt = -dir r omega sin zeta, db/dt = dir r omega cos zeta. 0 within 1e-9 of a reversal: sin(pi) is
// 1.2e-16, and an angle read back from a file is not exactly k * 90 deg.
double velocity_sign_a(double dir, double sin_zeta);
double velocity_sign_b(double dir, double cos_zeta);

// Angle travelled since the axis last reversed, in [0, pi): a reverses at zeta = k pi (phase 0), b at
// pi/2 + k pi (phase pi/2). zeta_rad is the axis' own angle (the commanded one less a servo lag).
double angle_since_reversal_rad(double zeta_rad, double phase_rad, double dir);

// Decay of a reversal spike t_s after it starts, exp(-t / tau): 0 before it starts and from
// spike_extent_decays tau on, where it is below 3.4e-4 of its height.
inline constexpr double spike_extent_decays = 8.0;
double reversal_spike_decay(double t_s, double tau_s);
// The decay time the diagnostics take for a spike when none stands out of the noise (identify.cpp);
// arcs.cpp asks whether the data holds a sample within its extent.
inline constexpr double assumed_spike_decay_s = 0.02;

// ---- Backlash deadband ----
// How far the axis has moved from its last extreme, r (1 - cos phi) at phi past its reversal; written
// 2 r sin^2(phi / 2) so that it keeps its digits near the reversal, where the deadband is taken up.
double rise_since_reversal_m(double radius_m, double angle_since_reversal_rad);

// Lost motion per unit backlash of a deadband of width backlash_m, along the axis (multiply by the
// backlash and project on the bar). An ideal step is -sign(velocity) / 2; a deadband stands still after
// a reversal until the drive has risen b from its extreme, lagging meanwhile by rise / b - 1/2 of b.
// backlash_m <= 0 gives the ideal step.
// Identification (identify.cpp) and EXPLAIN's backlash effect both use this one deadband, on the drives'
// tracks below.
// Inline: EXPLAIN's backlash generator calls it for every sample at every delay in every fold.
inline double deadband_lost_motion(double velocity_sign, double rise_m, double backlash_m) {
  const double taken_up = backlash_m > 0 ? std::clamp(rise_m / backlash_m - 0.5, -0.5, 0.5) : 0.5;
  return -velocity_sign * taken_up;
}

// ---- The drives' motion ----
// The drives' motion on the circle when they follow the command `delay_s` late, per sample: the direction each
// moves in since its last reversal and how far it has moved from that extreme. Computed once per identification
// or explanation for every delay searched (the deadband lives on it); their positions (a cyclic error's) are
// drive_position()'s.
// Each sample and axis is one float (a track per delay is the largest thing a DBB problem holds: 4 bytes rather
// than 9): its magnitude the rise r (1 - cos phi) (m), phi the angle past the axis's last reversal; its sign the
// direction since that reversal (at a reversal, where the rise is 0, the one it is about to take, so the
// deadband's lag is the approach's: -0 or +0). The float decides where a deadband is taken up; where it could not
// (a rise within its rounding of the width), lost_motion() makes the rise again exactly (drive_rise_m).
struct DriveTrack {
  double delay_s = 0;
  std::vector<float> a, b;
};
// The rise of an axis (phase 0: a, pi/2: b) at sample g when the drives follow delay_s late, exactly (m), and
// the direction it moves in since that reversal (-1 / +1).
double drive_rise_m(const SampleGeometry& g, double delay_s, double phase_rad);
double drive_direction(const SampleGeometry& g, double delay_s, double phase_rad);

// The drives' position (m, machine coordinates, {a, b}) at sample g when they follow the command delay_s late.
std::array<double, 2> drive_position(const SampleGeometry& g, double delay_s);

// The delays (s) by which the drives may follow the commanded angle of the runs: none when every run's
// angles were read from the axis encoders (metadata angle_source = encoders, as a live session writes),
// else a grid up to a slow position loop's 1/Kv (commanded angles, or angles from time and feed as a
// ballbar's software computes them).
std::vector<double> drive_delays_s(const std::vector<formats::DbbRun>& runs);

// Sample g appended to a track (its delay_s set).
void add_drive_sample(DriveTrack& track, const SampleGeometry& g);

// One track per delay over the samples `g` (any type derived from SampleGeometry).
template <class Geometry>
std::vector<DriveTrack> drive_tracks(const std::vector<Geometry>& g, const std::vector<double>& delays) {
  std::vector<DriveTrack> out;
  out.reserve(delays.size());
  for (const double d : delays) {
    DriveTrack& t = out.emplace_back();
    t.delay_s = d;
    // Sized once: a track per delay of every sample is the largest thing a DBB problem holds.
    for (auto* v : {&t.a, &t.b}) v->reserve(g.size());
    for (const SampleGeometry& p : g) add_drive_sample(t, p);
  }
  return out;
}

// Lost motion per unit backlash of a deadband of width b_a / b_b (m) along each axis ({a, b}) at
// sample i of the track, g its geometry: the same as deadband_lost_motion() of the exact rise. A float's rise
// is within 2^-24 of it: more than 1e-6 past the width, the deadband is taken up whichever it is.
inline double track_lost_motion(float packed, const SampleGeometry& g, double delay_s, double phase_rad, double width_m) {
  const double sign = std::signbit(packed) ? -1.0 : 1.0;  // -1 / +1 exactly as doubles
  const double rise = std::abs(static_cast<double>(packed));
  if (!(width_m > 0) || (rise >= std::numeric_limits<float>::min() && rise > width_m * (1 + 1e-6)))
    return deadband_lost_motion(sign, rise, width_m);
  return deadband_lost_motion(sign, drive_rise_m(g, delay_s, phase_rad), width_m);
}
inline std::array<double, 2> lost_motion(const DriveTrack& track, const SampleGeometry& g, std::size_t i, double b_a,
                                         double b_b) {
  return {track_lost_motion(track.a[i], g, track.delay_s, 0.0, b_a),
          track_lost_motion(track.b[i], g, track.delay_s, std::numbers::pi / 2, b_b)};
}

}  // namespace guideway::models::dbb
