#pragma once
// The instrument keys of a [[device]] table (docs/configuration.md "Instrument identity and
// calibration"): serial, calibration_certificate, calibrated_on, calibration_due and, for a ballbar,
// calibrated_length_mm and calibrated_length_u_um; and the warnings they give on a date.

#include <string>
#include <string_view>
#include <vector>

#include "core/instrument.hpp"
#include "core/toml_access.hpp"

namespace guideway::daemon {

// Throws ConfigError naming the file, line and key: a malformed or non-existent date, a calibration after
// `today` or a due date before it or over instrument_max_interval_years after it, an empty serial or
// certificate, a length or uncertainty outside its plausible range (docs/configuration.md), a calibrated
// length on a device that is no ballbar (driver dbb-can), an uncertainty without its length.
Instrument parse_instrument(const TableReader& device, std::string_view driver, const CalendarDate& today);

// The plausible ranges: a ballbar's calibrated length (bars with extensions reach 1.5 m; with the height
// of a tilted bar's socket, 3 m at most) and its standard uncertainty; a calibration's interval.
inline constexpr double instrument_max_length_mm = 3000.0;
inline constexpr double instrument_max_length_u_um = 1000.0;
inline constexpr int instrument_max_interval_years = 10;

}  // namespace guideway::daemon
