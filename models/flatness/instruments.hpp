#pragma once
// The slope-reading instruments a traverse or a slope profile comes from (docs/formats.md "Instrument
// profiles"): each named with its range, resolution and accuracy, hence the standard uncertainty of one
// reading; the range is checked on the readings' span about their middle (a tilt or a curvature within
// reach is accepted); and the readings' own scatter, to say when it and the instrument's u disagree.
// Pure functions; thread safe.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "models/flatness/angles.hpp"

namespace guideway::models::flatness {

struct InstrumentProfile {
  std::string_view name;         // as --instrument takes it
  std::string_view description;  // what it is, for --help and the docs
  Autocollimator instrument;
};

// autocollimator (TA80-style, the default of a traverse file), level (an electronic level), deflectometer
// (a long-trace profiler or nanometre-optic deflectometer, the default of a DABAM entry).
const std::vector<InstrumentProfile>& instrument_profiles();
// Throws std::invalid_argument naming the known profiles.
Autocollimator instrument_profile(std::string_view name);
// "autocollimator, level, deflectometer".
std::string instrument_names();

// Readings of one set-up (a file) must fit the instrument's range about their middle: the span
// max - min at most twice the range. `what` names them in the message ("pitch_arcsec"), `lines` their
// file lines (may be empty). Throws CsvError "source:line: ..." naming the two extreme readings.
void check_instrument_range(const std::vector<double>& angle_rad, const Autocollimator& instrument,
                            const std::string& what, const std::string& source, const std::vector<std::size_t>& lines);

// A reading's plausible bound (5.7 deg): beyond it a file holds no slope.
inline constexpr double max_abs_angle_rad = 0.1;

// Positions may jitter by this fraction of a step about the nominal spacing (an encoder's rounding, a
// stage's repeatability): each reading's own spacing is then used as measured.
inline constexpr double station_jitter_tolerance = 0.05;
// A spacing within this fraction of the step is on the grid (the rounding of decimal positions, not jitter).
inline constexpr double station_grid_tolerance = 1e-9;

// The readings' own scatter: the noise level of the finest db4 wavelet details (median absolute value /
// 0.6745, which smooth structure leaves near zero), from 16 readings on; NaN for fewer.
double reading_scatter_rad(const std::vector<double>& angle_rad);
// The factor beyond which the data's scatter and the instrument's stated u are said to disagree.
inline constexpr double u_disagreement_factor = 3.0;

}  // namespace guideway::models::flatness
