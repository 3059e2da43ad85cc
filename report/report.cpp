// The report (report.hpp): one self-contained HTML page with a section per analysis, printable on A4.
#include "report/report.hpp"

#include <algorithm>
#include <filesystem>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/csv_table.hpp"
#include "core/utc_time.hpp"
#include "formats/dbb_run.hpp"
#include "formats/raw_recording.hpp"
#include "report/html.hpp"
#include "report/sections.hpp"
#include "results/explanation.hpp"
#include "results/session_kinds.hpp"

namespace guideway::report {

namespace fs = std::filesystem;

std::string_view kind_name(InputKind kind) {
  switch (kind) {
    case InputKind::dbb_run:
      return results::dbb_kind.name;
    case InputKind::straightness:
      return results::straightness_kind.name;
    case InputKind::union_jack:
      return "unionjack";
    case InputKind::runout:
      return results::runout_kind.name;
    case InputKind::profile:
      return results::profile_kind.name;
    case InputKind::explain:
      return "explain";
    case InputKind::map:
      return "map";
  }
  return "unknown";
}

std::string base_name(const std::string& path) {
  const auto name = fs::path(path).filename().string();
  return name.empty() ? path : name;
}

InputKind detect_input(const std::string& path);

namespace {

// A raw recording is what a session measured, not a result: the files a session derived from it
// (NAME.run1.csv, NAME.traverse.csv, ...) sit beside it, and those are what a report reads.
ReportError raw_recording_refused(const std::string& path) {
  std::vector<std::string> inputs;
  for (const auto& d : formats::derived_files(path)) {
    try {
      detect_input(d);
      inputs.push_back(d);
    } catch (const ReportError&) {
      // not a report input (the session's PARAMS JSON, a part file, ...)
    }
  }
  return ReportError(formats::raw_recording_refusal(path, inputs, "a result"));
}

}  // namespace

InputKind detect_input(const std::string& path) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec || !fs::exists(status)) throw ReportError(path + ": no such file or directory");
  if (fs::is_directory(status)) {
    if (fs::exists(fs::path(path) / "Config.txt")) return InputKind::union_jack;
    throw ReportError(path + ": a directory is read as a Union Jack set, but it has no Config.txt");
  }
  const auto ext = fs::path(path).extension().string();
  if (ext == ".x3p") return InputKind::profile;
  if (ext == ".json") {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(read_text_file(path));
    } catch (const nlohmann::json::parse_error& e) {
      throw ReportError(path + ": not valid JSON (" + e.what() + ")");
    } catch (const CsvError& e) {
      throw ReportError(e.what());
    }
    if (results::is_explanation(j)) return InputKind::explain;
    if (j.is_object() && j.value("format", "") == "guideway/map/1") return InputKind::map;
    throw ReportError(path +
                      ": a JSON input must be an explanation (guideway explain --json: \"baseline\", "
                      "\"findings\") or an error map (guideway map fit --out: format guideway/map/1)");
  }
  CsvTable t;
  try {
    t = read_csv_table(path);
  } catch (const CsvError& e) {
    throw ReportError(e.what());
  }
  if (const auto f = t.metadata.find("format"); f != t.metadata.end()) {
    if (f->second == "guideway/dbb-run/1") return InputKind::dbb_run;
    if (f->second == "guideway/profile/1") return InputKind::profile;
    if (f->second == formats::raw_format_id) throw raw_recording_refused(path);
    // Other formats fall through to the columns (e.g. a run-out written with its own format name).
  }
  const auto has = [&](std::string_view c) { return t.find_column(c).has_value(); };
  if (has("angle_deg") && has("dL_um")) return InputKind::dbb_run;
  if (has("x_mm") && has("pitch_arcsec")) return InputKind::straightness;
  if (has("angle_deg") && has("runout_um")) return InputKind::runout;
  for (const char* x : {"x_mm", "x_um", "x_m"})
    for (const char* z : {"z_um", "z_nm", "z_mm", "z_m"})
      if (has(x) && has(z)) return InputKind::profile;
  std::string cols;
  for (const auto& c : t.columns) cols += (cols.empty() ? "" : ",") + c;
  throw ReportError(path + ": not a recognised input (columns " + cols +
                    "); expected a DBB run (format = guideway/dbb-run/1), a straightness traverse (x_mm,pitch_arcsec), "
                    "a run-out revolution (angle_deg,runout_um), a profile (x_mm,z_um), a Union Jack directory or an "
                    "explanation JSON");
}

std::string render_report(const std::vector<std::string>& inputs, const ReportOptions& options) {
  if (inputs.empty()) throw ReportError("report: no inputs");
  std::vector<std::pair<std::string, InputKind>> items;
  for (const auto& p : inputs) items.emplace_back(p, detect_input(p));

  std::ostringstream body;
  std::vector<TocEntry> toc;
  std::map<std::string, int> counts;
  const auto next_id = [&](std::string_view kind) {
    const std::string k(kind);
    return k + "-" + std::to_string(++counts[k]);
  };
  // Profiles (CSV) with the carriage's traverse: Mu's correlation, shown under the last profile.
  std::vector<std::string> profile_csvs;
  std::string traverse, runout, correlation;
  std::size_t last_profile = items.size();
  for (std::size_t i = 0; i < items.size(); ++i) {
    const auto& [p, k] = items[i];
    if (k == InputKind::profile) {
      last_profile = i;
      if (fs::path(p).extension() != ".x3p") profile_csvs.push_back(p);
    }
    if (k == InputKind::straightness && traverse.empty()) traverse = p;
    if (k == InputKind::runout && runout.empty()) runout = p;
  }
  if (!profile_csvs.empty() && !traverse.empty())
    correlation = workpiece_correlation_html(profile_csvs, traverse, runout, options);

  if (!options.instruments.empty()) {
    const std::string id = next_id("instruments");
    body << instruments_section(options.instruments, options.instruments_checked_on.value_or(utc_today()), id);
    toc.push_back({id, "Instruments"});
  }
  bool dbb_done = false;
  for (std::size_t i = 0; i < items.size(); ++i) {
    const auto& [path, kind] = items[i];
    std::string id = next_id(kind_name(kind));
    std::string html;
    switch (kind) {
      case InputKind::dbb_run: {
        if (dbb_done) continue;  // all runs go into the first DBB section(s)
        // Runs are identified together, except runs of a compensation check (`compensation = before|after`
        // metadata, guideway compensate --verify): one section per stage, so before and after sit side by side.
        std::vector<std::pair<std::string, std::vector<std::string>>> groups;
        for (const auto& [p, k] : items) {
          if (k != InputKind::dbb_run) continue;
          std::string stage;
          try {
            const auto run = formats::read_dbb_run(p);
            if (const auto f = run.metadata.find("compensation"); f != run.metadata.end()) stage = f->second;
          } catch (const std::exception&) {
            // dbb_section reports the file's error
          }
          auto g = std::find_if(groups.begin(), groups.end(), [&](const auto& e) { return e.first == stage; });
          if (g == groups.end()) g = groups.insert(groups.end(), {stage, {}});
          g->second.push_back(p);
        }
        // Before, then after, whatever order the files came in (a shell's glob puts after_* first).
        std::stable_partition(groups.begin(), groups.end(), [](const auto& g) { return g.first != "after"; });
        for (std::size_t n = 0; n < groups.size(); ++n) {
          const auto& [stage, runs] = groups[n];
          const std::string gid = n == 0 ? id : next_id(kind_name(kind));
          body << dbb_section(runs, gid, options.identified);
          toc.push_back({gid, "Double ball bar (" + std::to_string(runs.size()) + " runs" +
                                  (stage.empty() ? std::string() : ", " + stage + " compensation") + ")"});
        }
        dbb_done = true;
        break;
      }
      case InputKind::straightness:
        html = straightness_section(path, id);
        toc.push_back({id, "Straightness: " + base_name(path)});
        break;
      case InputKind::union_jack:
        html = union_jack_section(path, id);
        toc.push_back({id, "Union Jack: " + base_name(path)});
        break;
      case InputKind::runout:
        html = runout_section(path, id);
        toc.push_back({id, "Run-out: " + base_name(path)});
        break;
      case InputKind::profile:
        html = profile_section(path, id, options,
                               i == last_profile || correlation.empty()
                                   ? correlation
                                   : "<p>The correlation with the carriage errors is under the last profile.</p>");
        toc.push_back({id, "Profile: " + base_name(path)});
        break;
      case InputKind::explain:
        html = explain_section(path, id);
        toc.push_back({id, "Explanation: " + base_name(path)});
        break;
      case InputKind::map:
        try {
          html = map_section(nlohmann::json::parse(read_text_file(path)), path, id);
        } catch (const std::invalid_argument& e) {
          throw ReportError(e.what());
        } catch (const nlohmann::json::exception& e) {
          // The map read (map_from_json checks it), a part shown only to people (checks, groups, volumetric) not.
          throw ReportError(path + ": not an error map as `guideway map fit` writes it (" + e.what() + ")");
        }
        toc.push_back({id, "Error map: " + base_name(path)});
        break;
    }
    body << html;
  }
  return html_document(options.title, options.subtitle, toc, body.str());
}

}  // namespace guideway::report
