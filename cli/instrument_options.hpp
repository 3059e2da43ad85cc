#pragma once
// The slope instrument a traverse or a slope profile was read with, as `identify straightness`, `identify
// flatness --straightness` and `explain --model traverse` take it: a named profile (models/flatness/
// instruments.hpp; default: the deflectometer for a DABAM entry, the autocollimator otherwise) and explicit
// overrides of its range and its u per reading.

#include <string>

#include <CLI/CLI.hpp>

#include "models/flatness/instruments.hpp"
#include "models/flatness/straightness.hpp"

namespace guideway::cli {

struct InstrumentOptions {
  std::string name;  // "" = the file's default
  double range_arcsec = 0.0;
  double u_arcsec = 0.0;

  void add(CLI::App& cmd) {
    cmd.add_option("--instrument", name,
                   "what read the angles: " + models::flatness::instrument_names() +
                       " (default: deflectometer for a DABAM entry, autocollimator otherwise; docs/formats.md "
                       "\"Instrument profiles\")");
    cmd.add_option("--range-arcsec", range_arcsec,
                   "the instrument's range, +- about the readings' middle (default: its profile's)")
        ->check(CLI::PositiveNumber);
    cmd.add_option("--angle-u-arcsec", u_arcsec,
                   "standard uncertainty per reading (default: its profile's, sqrt(resolution^2/12 + accuracy^2/3); "
                   "TA80: 0.289 arcsec)")
        ->check(CLI::PositiveNumber);
  }

  // The instrument for `path`; throws std::invalid_argument for an unknown name.
  [[nodiscard]] models::flatness::Autocollimator of(const std::string& path) const {
    models::flatness::Autocollimator a =
        name.empty() ? models::flatness::default_instrument(path) : models::flatness::instrument_profile(name);
    if (range_arcsec > 0) a.range_rad = range_arcsec * models::flatness::rad_per_arcsec;
    if (u_arcsec > 0) a.u_override_rad = u_arcsec * models::flatness::rad_per_arcsec;
    return a;
  }
};

}  // namespace guideway::cli
