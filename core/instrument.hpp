#pragma once
// Which instrument made a measurement and its calibration, as the [[device]] table states them
// (docs/configuration.md "Instrument identity and calibration"): carried into every recording's header
// (formats/raw_recording), every PARAMS/EXPLAIN (results/result_header), the session's report and the
// fleet's history, so a result is traceable to a certificate. Pure; thread safe.

#include <optional>
#include <string>

#include "core/utc_time.hpp"

namespace guideway {

struct Instrument {
  std::string serial;                   // the instrument's serial number, as on its plate and certificate
  std::string calibration_certificate;  // the certificate's number
  std::optional<CalendarDate> calibrated_on;
  std::optional<CalendarDate> calibration_due;  // valid through this day, expired from the next
  // A ballbar: its calibrated length (the reading at the encoder's zero count) and that length's
  // standard uncertainty, which enters the uncertainty of what depends on it (docs/conventions.md).
  std::optional<double> calibrated_length_mm;
  std::optional<double> calibrated_length_u_um;

  // Nothing stated: a device the configuration says nothing about.
  [[nodiscard]] bool empty() const noexcept {
    return serial.empty() && calibration_certificate.empty() && !calibrated_on && !calibration_due &&
           !calibrated_length_mm && !calibrated_length_u_um;
  }
  bool operator==(const Instrument&) const = default;
};

// Whether its calibration had run out on `on` (the day after calibration_due or later); false without
// a due date.
[[nodiscard]] bool calibration_expired(const Instrument& instrument, const CalendarDate& on) noexcept;

// The warning a user reads when the calibration had run out on `on`, naming the device, serial and
// certificate: "device dbb (serial 1001, certificate C-17): calibration was due 2024-01-10, 412 days
// before 2025-02-25: recalibrate the instrument or update calibration_due"; "" when it had not.
[[nodiscard]] std::string calibration_warning(const std::string& device, const Instrument& instrument,
                                              const CalendarDate& on);

// "serial 1001, certificate C-17" (the parts stated), for messages; "" when neither is.
[[nodiscard]] std::string instrument_identity_text(const Instrument& instrument);

}  // namespace guideway
