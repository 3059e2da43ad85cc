// The instrument keys of a [[device]] table (instrument_config.hpp): identity, calibration, their warnings.
#include "daemon/instrument_config.hpp"

#include <cmath>
#include <sstream>

namespace guideway::daemon {

namespace {

// The ballbar driver, whose sessions use the bar's calibrated length.
constexpr std::string_view ballbar_driver = "dbb-can";

std::string number_text(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

}  // namespace

Instrument parse_instrument(const TableReader& t, std::string_view driver, const CalendarDate& today) {
  Instrument in;
  for (const auto& [key, value] : {std::pair{"serial", &in.serial}, {"calibration_certificate", &in.calibration_certificate}}) {
    *value = t.get_string(key, "");
    if (t.has(key) && value->find_first_not_of(" \t") == std::string::npos)
      t.fail(key, "is empty: state it as on the instrument's plate or certificate, or leave the key out");
  }
  in.calibrated_on = t.get_date("calibrated_on");
  in.calibration_due = t.get_date("calibration_due");
  if (in.calibrated_on && today < *in.calibrated_on)
    t.fail("calibrated_on", to_iso(*in.calibrated_on) + " is after today (" + to_iso(today) +
                                "): a calibration is stated once it was made");
  if (in.calibrated_on && in.calibration_due && *in.calibration_due < *in.calibrated_on) {
    t.fail("calibration_due", to_iso(*in.calibration_due) + " is before calibrated_on (" + to_iso(*in.calibrated_on) +
                                  "): the due date comes after the calibration");
  }
  if (in.calibration_due) {
    const CalendarDate from = in.calibrated_on.value_or(today);
    const CalendarDate latest{from.year + instrument_max_interval_years, from.month, from.day == 29 && from.month == 2 ? 28 : from.day};
    if (latest < *in.calibration_due)
      t.fail("calibration_due", to_iso(*in.calibration_due) + " is more than " +
                                    std::to_string(instrument_max_interval_years) + " years after " +
                                    (in.calibrated_on ? "calibrated_on (" : "today (") + to_iso(from) +
                                    "): no certificate runs that long");
  }
  for (const char* key : {"calibrated_length_mm", "calibrated_length_u_um"}) {
    if (t.has(key) && driver != ballbar_driver) {
      t.fail(key, "applies to a ballbar (driver \"" + std::string(ballbar_driver) + "\"), not to driver \"" +
                      std::string(driver) + "\"");
    }
  }
  if (t.has("calibrated_length_mm")) {
    const double l = t.get_double("calibrated_length_mm", 0.0);
    if (!(l > 0) || !std::isfinite(l))
      t.fail("calibrated_length_mm", "must be a positive length, got " + number_text(l));
    if (l > instrument_max_length_mm)
      t.fail("calibrated_length_mm", number_text(l) + " mm is over " + number_text(instrument_max_length_mm) +
                                         " mm, a ballbar's length (with extensions)");
    in.calibrated_length_mm = l;
  }
  if (t.has("calibrated_length_u_um")) {
    const double u = t.get_double("calibrated_length_u_um", 0.0);
    if (!(u >= 0) || !std::isfinite(u)) {
      t.fail("calibrated_length_u_um",
             "a standard uncertainty is zero or positive, got " + number_text(u) + " (the certificate's u, in um)");
    }
    if (u > instrument_max_length_u_um)
      t.fail("calibrated_length_u_um", number_text(u) + " um is over " + number_text(instrument_max_length_u_um) +
                                           " um: a bar known no better than a millimetre is not calibrated");
    if (!in.calibrated_length_mm) {
      t.fail("calibrated_length_u_um", "needs calibrated_length_mm (the length it is the uncertainty of)");
    }
    in.calibrated_length_u_um = u;
  }
  return in;
}

}  // namespace guideway::daemon
