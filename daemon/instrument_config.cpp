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

Instrument parse_instrument(const TableReader& t, std::string_view driver) {
  Instrument in;
  in.serial = t.get_string("serial", "");
  in.calibration_certificate = t.get_string("calibration_certificate", "");
  in.calibrated_on = t.get_date("calibrated_on");
  in.calibration_due = t.get_date("calibration_due");
  if (in.calibrated_on && in.calibration_due && *in.calibration_due < *in.calibrated_on) {
    t.fail("calibration_due", to_iso(*in.calibration_due) + " is before calibrated_on (" + to_iso(*in.calibrated_on) +
                                  "): the due date comes after the calibration");
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
    in.calibrated_length_mm = l;
  }
  if (t.has("calibrated_length_u_um")) {
    const double u = t.get_double("calibrated_length_u_um", 0.0);
    if (!(u >= 0) || !std::isfinite(u)) {
      t.fail("calibrated_length_u_um",
             "a standard uncertainty is zero or positive, got " + number_text(u) + " (the certificate's u, in um)");
    }
    if (!in.calibrated_length_mm) {
      t.fail("calibrated_length_u_um", "needs calibrated_length_mm (the length it is the uncertainty of)");
    }
    in.calibrated_length_u_um = u;
  }
  return in;
}

}  // namespace guideway::daemon
