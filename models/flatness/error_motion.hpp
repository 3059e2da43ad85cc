#pragma once
// Spindle error motion from a run-out record of several revolutions, as ISO 230-7 defines its values
// (docs/formats.md, "Run-out revolution"; docs/cli.md, `guideway identify runout`). The probe reads a
// face at a radius, so its once-per-revolution term is the face's tilt to the spindle axis (a set-up
// term, the one Mu's Eq. 21 turns into squareness): like the centring of a radial or the tilt of a face
// measurement in the standard, it is removed (the least-squares sinusoid of order 1 and the mean, the
// analogue of the least-squares centre) before any value is taken. Then:
//   total        peak-to-valley of the whole record (every revolution, every sample as measured);
//   synchronous  the record resampled on one angle grid and averaged over the revolutions at each
//                angle: its peak-to-valley (what repeats every revolution: spindle and artifact form);
//   asynchronous the largest spread across the revolutions at one angle (what does not repeat:
//                bearing defects at non-integer orders, growth, noise).
// Only whole revolutions from the first sample count (a sample standing for the step to the next). Pure functions;
// thread safe; SI units.

#include <cstddef>
#include <string>
#include <vector>

namespace guideway::models::flatness {

struct ErrorMotionResult {
  std::size_t revolutions = 0;         // whole revolutions used
  std::size_t samples = 0;             // samples in them
  std::size_t points_per_rev = 0;      // the angle grid of the synchronous average
  double fundamental_m = 0.0;          // amplitude of the removed once-per-revolution term
  double fundamental_phase_rad = 0.0;  // angle of its maximum, [0, 2 pi)
  double total_m = 0.0;
  double synchronous_m = 0.0;
  double asynchronous_m = 0.0;              // 0 with one revolution
  std::vector<double> synchronous_curve_m;  // the average revolution, points_per_rev values from angle 0
};

// Donaldson's reversal on a face: two records whose angles share the spindle's zero, the artifact (the
// plate) turned by `turned` about the axis between them, the probe where it was. The spindle's synchronous
// error motion S stays at its spindle angle, the artifact's form F turns with it, so at order k the two
// average revolutions are A_k = S_k + F_k and B_k = S_k + F_k e^(-i k turned): F_k = (A_k - B_k) /
// (1 - e^(-i k turned)), S_k = A_k - F_k (for 180 deg: S = (A + B) / 2, F = (A - B) / 2 at odd orders).
// An order the turn moves by less than 60 deg (|1 - e^(-i k turned)| < 1: at 180 deg every even order,
// whose form a half turn brings back onto itself) is not separated: it stays in the spindle's curve as
// the mean of A_k and B_k, and is listed.
struct ReversalResult {
  double turned_rad = 0.0;
  std::size_t points_per_rev = 0;
  std::vector<double>
      spindle_curve_m;  // the spindle's synchronous error motion, the form removed, from the spindle's zero
  std::vector<double> form_curve_m;    // the artifact's form as the first record reads it, from the spindle's zero
  double spindle_synchronous_m = 0.0;  // their peaks-to-valleys
  double artifact_form_m = 0.0;
  std::vector<int> together_orders;  // orders from 2 the turn does not separate (in the spindle's curve)
};

// first, turned: the error motions of the two records; first_zero_rad, turned_zero_rad: the spindle
// angle of each record's first sample (where its average revolution starts). Throws std::invalid_argument
// when the turn separates no order.
ReversalResult separate_reversal(const ErrorMotionResult& first, double first_zero_rad, const ErrorMotionResult& turned,
                                 double turned_zero_rad, double turned_rad);

// The whole revolutions a record of increasing angles covers (each sample standing for the step to the
// next): what error_motion uses.
std::size_t whole_revolutions(const std::vector<double>& angle_rad);

// angle_rad: the spindle angle of each sample, increasing, counted on over revolutions (0 .. 2 pi n);
// value_m: the reading. Throws std::invalid_argument naming `source` when less than one whole
// revolution is recorded, angles do not increase, or a revolution has fewer than 8 samples.
ErrorMotionResult error_motion(const std::vector<double>& angle_rad, const std::vector<double>& value_m,
                               const std::string& source);

}  // namespace guideway::models::flatness
