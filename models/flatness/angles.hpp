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

}  // namespace guideway::models::flatness
