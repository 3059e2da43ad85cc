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

// Throws ConfigError naming the file, line and key: a malformed or non-existent date, a due date before
// the calibration, a negative or non-finite length or uncertainty, a calibrated length on a device that
// is no ballbar (driver dbb-can), an uncertainty without its length.
Instrument parse_instrument(const TableReader& device, std::string_view driver);

}  // namespace guideway::daemon
