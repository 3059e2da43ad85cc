// The report's instruments section (sections.hpp): each instrument with its serial, certificate and calibration date
// checked.
#include <cstdio>

#include "report/html.hpp"
#include "report/sections.hpp"

namespace guideway::report {

namespace {

std::string date_cell(const std::optional<CalendarDate>& d) { return d ? to_iso(*d) : std::string("&ndash;"); }

std::string text_cell(const std::string& s) { return s.empty() ? std::string("&ndash;") : html_escape(s); }

std::string length_cell(const Instrument& in) {
  if (!in.calibrated_length_mm) return "&ndash;";
  char buf[96];
  if (in.calibrated_length_u_um)
    std::snprintf(buf, sizeof buf, "%.4f mm (u = %g &micro;m)", *in.calibrated_length_mm, *in.calibrated_length_u_um);
  else
    std::snprintf(buf, sizeof buf, "%.4f mm", *in.calibrated_length_mm);
  return buf;
}

}  // namespace

std::string instruments_section(const std::vector<ReportInstrument>& instruments, const CalendarDate& checked_on,
                                const std::string& id) {
  Table table("Instruments of these measurements and their calibration, judged on " + to_iso(checked_on),
              {"Device", "Serial", "Certificate", "Calibrated on", "Due", "Calibrated length", "Calibration"});
  table.text_columns = {1, 2, 6};
  std::string notes;
  for (const auto& [device, in] : instruments) {
    const bool expired = calibration_expired(in, checked_on);
    const std::string status = !in.calibration_due ? "no due date stated"
                               : expired           ? "<strong>EXPIRED</strong>"
                                                   : "valid";
    table.rows.push_back({html_escape(device), text_cell(in.serial), text_cell(in.calibration_certificate),
                          date_cell(in.calibrated_on), date_cell(in.calibration_due), length_cell(in), status});
    if (expired) notes += html_note("Warning: " + calibration_warning(device, in, checked_on) + ".");
  }
  return html_section("instruments", id, "Instruments", html_table(table) + notes);
}

}  // namespace guideway::report
