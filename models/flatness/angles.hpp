#pragma once
// Angle units and the slope-reading instrument as an uncertainty source: by default the TA80-style
// autocollimator (Mu 2012, Sec. 4.1: range +-600", resolution 0.01", accuracy 0.5"); the other named
// instruments (an electronic level, a deflectometer) in instruments.hpp.

#include <cmath>
#include <string>
#include <numbers>

#include "core/units.hpp"

namespace guideway::models::flatness {

using guideway::rad_per_arcsec;
inline constexpr double metres_per_inch = 0.0254;

// The instrument: per-reading standard uncertainty u = sqrt(resolution^2/12 + accuracy^2/3), i.e.
// rectangular distributions of half-width resolution/2 and accuracy, independent between readings. The
// range is about the readings' middle (the instrument is aimed at, or zeroed on, the surface: a mounting
// tilt within its reach is the set-up, not a reading out of range).
struct Autocollimator {
  std::string name = "autocollimator";  // as instruments.hpp names it
  double range_rad = 600.0 * rad_per_arcsec;
  double resolution_rad = 0.01 * rad_per_arcsec;
  double accuracy_rad = 0.5 * rad_per_arcsec;
  double u_override_rad = 0.0;  // > 0: use this per-reading standard uncertainty instead

  [[nodiscard]] double reading_u_rad() const {
    if (u_override_rad > 0) return u_override_rad;
    return std::sqrt(resolution_rad * resolution_rad / 12.0 + accuracy_rad * accuracy_rad / 3.0);
  }
};

// A carriage traverse of machine axis `axis` (0 x, 1 y, 2 z; docs/conventions.md "Autocollimator traverse of
// any axis"): a traverse file's angles are slopes of the carriage's path along the axis, pitch in the vertical
// direction (X, Y: z; Z: x), yaw in the horizontal one (X: y; Y: x; Z: y). The carriage's rotation about its
// pitch axis (X: y, Y: x, Z: y) is traverse_pitch_sign(axis) times the pitch slope, about its yaw axis (X: z,
// Y: z, Z: x) traverse_yaw_sign(axis) times the yaw slope (and the slopes the same signs times the rotations).
[[nodiscard]] inline constexpr double traverse_pitch_sign(int axis) { return axis == 0 ? -1.0 : 1.0; }
[[nodiscard]] inline constexpr double traverse_yaw_sign(int axis) { return axis == 0 ? 1.0 : -1.0; }

}  // namespace guideway::models::flatness
