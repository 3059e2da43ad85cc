#pragma once
// Reports a metrologist would rather look at than read (docs/reports.md): one self-contained HTML page
// (inline SVG and CSS, no scripts, nothing fetched; printable on A4) with one section per analysis:
//   - DBB runs (`guideway/dbb-run/1`): identified together (Lai's third-order model + ballbar
//     diagnostics, models/dbb); a polar plot per set-up with CW/CCW overlaid on a magnified scale
//     (its um/division stated), the diagnostics with uncertainties, the ISO 230-4 figures.
//   - Straightness traverses (`x_mm,pitch_arcsec[,yaw_arcsec]`): the profile with its end-point and
//     least-squares lines and the polynomial fit (models/flatness).
//   - Union Jack sets (a directory with Config.txt): the plate as a height map.
//   - Run-out revolutions (`angle_deg,runout_um`): the revolution and its once-per-revolution fit.
//   - Profiles (`guideway/profile/1`, `x_mm,z_um`): the profile and its wavelet MRA panels
//     a1..a5, d1..d5 (Mu 2012 Figure 7; db1, dsp/wavelet); with a straightness traverse among the
//     inputs, the correlation bars before/after the wavelet step (Figures 8-9, workpiece_flatness).
//   - Explanations (the JSON of `guideway explain --json`): residual RMS before/after each finding,
//     in-sample and held out, the finding and mismatch tables, the residual curves it carries.
//   - Error maps (`guideway map fit --out`, format guideway/map/1): the 21 errors with their uncertainty bands,
//     the error vectors on the volume's faces, the volumetric accuracy, what was not determined, the
//     cross-checks (models/map).
// Inputs are recognised by their `# format =` metadata or their columns (detect_input). Pure apart from
// reading the inputs; thread safe. Errors are ReportError with the file (and line) in the message.

#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/instrument.hpp"
#include "models/explain/dbb_checked.hpp"

namespace guideway::report {

class ReportError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class InputKind { dbb_run, straightness, union_jack, runout, profile, explain, map };

[[nodiscard]] std::string_view kind_name(InputKind kind);  // "dbb", "straightness", ...

// What a path holds: a directory with Config.txt is a Union Jack set; a .json file an explanation
// (results::is_explanation) or an error map; a CSV by its `format` metadata, else by its columns. Throws ReportError
// "PATH: ..." naming what was expected when the input is none of these.
[[nodiscard]] InputKind detect_input(const std::string& path);

// An instrument the report's measurements were made with, on its device.
struct ReportInstrument {
  std::string device;
  Instrument instrument;
};

struct ReportOptions {
  std::string title = "Guideway report";
  std::string subtitle;       // e.g. the time it was generated (the page itself has no clock)
  std::string wavelet = "db1";  // MRA of profiles (Mu 2012 use db1, 5 levels)
  int wavelet_level = 5;
  // The "Instruments" table at the top (none: no table): identity, certificate, dates, the bar's length,
  // and whether each calibration had run out on `instruments_checked_on` (default: today, UTC).
  std::vector<ReportInstrument> instruments;
  std::optional<CalendarDate> instruments_checked_on;
  // What a session identified from the DBB runs it wrote, one per plane, as its PARAMS published it (with
  // EXPLAIN's findings fitted beside): the DBB section shows it instead of identifying the run files again,
  // and says so. A plane's runs are taken as the session's when they are as many, in the same directions,
  // with as many points. Empty (`guideway report FILES`): the runs are identified from the files.
  std::vector<models::explain::CheckedIdentification> identified;
};

// The report for these inputs (files or Union Jack directories), in the order given; all DBB runs are
// identified together as one multi-pattern test. Returns the HTML page. Throws ReportError for an
// unreadable or unrecognised input (the message names the file and, for bad rows, the line); an
// identification that refuses the data is shown in the report as a note, not thrown.
//
// For the daemon's session report: render_report(the session's files, options with its identification).
[[nodiscard]] std::string render_report(const std::vector<std::string>& inputs, const ReportOptions& options = {});

// The report of one error map given as its JSON (models/map/map_json; `guideway map fit --report`).
[[nodiscard]] std::string render_map_report(const nlohmann::json& map, const ReportOptions& options = {});

}  // namespace guideway::report
