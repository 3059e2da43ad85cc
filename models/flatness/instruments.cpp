// The slope-reading instruments (instruments.hpp): each named with its range, resolution and one reading's uncertainty.
#include "models/flatness/instruments.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"
#include "dsp/denoise.hpp"
#include "dsp/wavelet.hpp"

namespace guideway::models::flatness {

namespace {

Autocollimator make(std::string_view name, double range_arcsec, double resolution_urad, double accuracy_urad) {
  Autocollimator a;
  a.name = std::string(name);
  a.range_rad = range_arcsec * rad_per_arcsec;
  a.resolution_rad = resolution_urad * 1e-6;
  a.accuracy_rad = accuracy_urad * 1e-6;
  return a;
}

}  // namespace

const std::vector<InstrumentProfile>& instrument_profiles() {
  static const std::vector<InstrumentProfile> all = [] {
    std::vector<InstrumentProfile> v;
    v.push_back({"autocollimator",
                 "TA80-style autocollimator (Mu 2012): range +-600\", resolution 0.01\", accuracy 0.5\" (u 0.289\" a "
                 "reading)",
                 Autocollimator{}});
    v.push_back(
        {"level",
         "electronic level: range +-1 mm/m (+-206\"), resolution 1 um/m, accuracy 1 um/m (u 0.65 urad = 0.133\" "
         "a reading)",
         make("level", 1e-3 / rad_per_arcsec, 1.0, 1.0)});
    v.push_back({"deflectometer",
                 "deflectometer or long-trace profiler (NOM, LTP; DABAM's instruments): range +-10 mrad (+-2063\"), "
                 "resolution 0.01 urad, accuracy 0.2 urad (u 0.116 urad = 0.024\" a reading)",
                 make("deflectometer", 10e-3 / rad_per_arcsec, 0.01, 0.2)});
    return v;
  }();
  return all;
}

std::string instrument_names() {
  std::string out;
  for (const auto& p : instrument_profiles()) out += (out.empty() ? "" : ", ") + std::string(p.name);
  return out;
}

Autocollimator instrument_profile(std::string_view name) {
  for (const auto& p : instrument_profiles())
    if (p.name == name) return p.instrument;
  throw std::invalid_argument("unknown instrument '" + std::string(name) + "' (known: " + instrument_names() + ")");
}

void check_instrument_range(const std::vector<double>& angle_rad, const Autocollimator& instrument,
                            const std::string& what, const std::string& source, const std::vector<std::size_t>& lines) {
  if (angle_rad.empty()) return;
  const auto [lo, hi] = std::minmax_element(angle_rad.begin(), angle_rad.end());
  if (!(*hi - *lo > 2 * instrument.range_rad)) return;
  const auto lo_i = static_cast<std::size_t>(lo - angle_rad.begin()),
             hi_i = static_cast<std::size_t>(hi - angle_rad.begin());
  const auto where = [&](std::size_t i) { return i < lines.size() ? source + ":" + std::to_string(lines[i]) : source; };
  const double as = 1.0 / rad_per_arcsec;
  throw CsvError(where(std::max(lo_i, hi_i)) + ": " + what + " spans " + significant_digits(*hi * as - *lo * as, 6) +
                 "\" (from " + significant_digits(*lo * as, 8) + " at " + where(lo_i) + " to " +
                 significant_digits(*hi * as, 8) + " at " + where(hi_i) + "), more than the " + instrument.name +
                 "'s range +-" + significant_digits(instrument.range_rad * as, 6) +
                 "\" about the readings' middle (--instrument " + instrument_names() + ", or --range-arcsec)");
}

double reading_scatter_rad(const std::vector<double>& angle_rad) {
  if (angle_rad.size() < 16) return std::numeric_limits<double>::quiet_NaN();
  static const dsp::Wavelet db4("db4");
  const auto bands = dsp::dwt(angle_rad, db4, dsp::Mode::periodization);
  // The last coefficients (half the filter less one) wrap around the ends: they see the jump between the last
  // reading and the first.
  const auto wrap = static_cast<std::ptrdiff_t>(db4.filter_length() / 2 - 1);
  std::vector<double> inner(bands.detail.begin(), bands.detail.end() - wrap);
  return dsp::mad_sigma(inner);
}

}  // namespace guideway::models::flatness
