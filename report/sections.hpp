#pragma once
// One report section per analysis (report.hpp lists them). Each reads its input(s), runs the project's
// own model, and returns the <section> HTML. Readers' errors come out as ReportError with their
// "file:line: message"; a model that refuses the data becomes a note in the section.

#include <string>
#include <vector>

#include "report/report.hpp"

namespace guideway::report {

// `identified`: ReportOptions::identified, shown for the planes whose runs it matches.
std::string dbb_section(const std::vector<std::string>& paths, const std::string& id,
                        const std::vector<models::explain::CheckedIdentification>& identified = {});
std::string straightness_section(const std::string& path, const std::string& id);
std::string union_jack_section(const std::string& path, const std::string& id);
std::string runout_section(const std::string& path, const std::string& id);
// correlation_html: the workpiece correlation of the report's profiles (workpiece_correlation_html), shown in
// the last profile's section; empty: a note says what it needs.
std::string profile_section(const std::string& path, const std::string& id, const ReportOptions& options,
                            const std::string& correlation_html);
// Mu 2012 Figures 8-9 as bars, from models/flatness/workpiece_flatness: the profiles (CSV, with feed and
// spindle speed) against the simulated squareness and the straightness of the X traverse, before and after
// the wavelet step, the squareness identified from them and, with a run-out file, Eq. 21's check. The
// model refusing the data gives a note.
std::string workpiece_correlation_html(const std::vector<std::string>& profiles, const std::string& traverse,
                                       const std::string& runout, const ReportOptions& options);
std::string explain_section(const std::string& path, const std::string& id);
// An error map's JSON (models/map/map_json), `source` naming it.
std::string map_section(const nlohmann::json& map, const std::string& source, const std::string& id);
// The instruments of ReportOptions: one row each, a highlighted note per calibration that had run out.
std::string instruments_section(const std::vector<ReportInstrument>& instruments, const CalendarDate& checked_on,
                                const std::string& id);

// The file name without its directories.
std::string base_name(const std::string& path);

}  // namespace guideway::report
