// An instrument's identity and calibration as text, and whether its calibration has run out (instrument.hpp).
#include "core/instrument.hpp"

namespace guideway {

bool calibration_expired(const Instrument& instrument, const CalendarDate& on) noexcept {
  return instrument.calibration_due && on > *instrument.calibration_due;
}

std::string instrument_identity_text(const Instrument& instrument) {
  std::string out;
  if (!instrument.serial.empty()) out = "serial " + instrument.serial;
  if (!instrument.calibration_certificate.empty())
    out += (out.empty() ? "" : ", ") + std::string("certificate ") + instrument.calibration_certificate;
  return out;
}

std::string calibration_warning(const std::string& device, const Instrument& instrument, const CalendarDate& on) {
  if (!calibration_expired(instrument, on)) return {};
  const long days = days_between(*instrument.calibration_due, on);
  const std::string who = instrument_identity_text(instrument);
  return "device " + device + (who.empty() ? "" : " (" + who + ")") + ": calibration was due " +
         to_iso(*instrument.calibration_due) + ", " + std::to_string(days) + (days == 1 ? " day" : " days") +
         " before " + to_iso(on) + ": recalibrate the instrument or update calibration_due";
}

}  // namespace guideway
