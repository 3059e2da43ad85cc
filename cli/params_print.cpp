// PARAMS and EXPLAIN as people read them (params_print.hpp).
#include "cli/params_print.hpp"

#include "cli/daemon_client.hpp"
#include "cli/instrument_print.hpp"
#include "core/number_format.hpp"
#include "core/printable.hpp"
#include "core/units.hpp"
#include "results/message_class.hpp"
#include "results/parameters.hpp"
#include "results/params.hpp"
#include "results/result_header.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace guideway::cli {

namespace {

// Below this part of G an error is listed in one line with the others as small ("what to fix first").
constexpr double negligible_percent = 1.0;

double number_or(const nlohmann::json& j, const char* key, double fallback) {
  const nlohmann::json v = j.value(key, nlohmann::json());
  return v.is_number() ? v.get<double>() : fallback;
}

std::vector<std::string> shown_row(const std::string& name, const nlohmann::json& v, std::string_view plane,
                                   std::string_view group) {
  const results::Shown s = results::shown(name, number_or(v, "value", NAN), number_or(v, "u", NAN), plane, group);
  if (v.contains("not_determined")) return {s.label, "not determined", ""};  // why: in the notes
  return {s.label, s.value, s.unit};
}

std::vector<std::string> shown_row(const results::Figure& f, std::string_view plane, std::string_view group) {
  const results::Shown s = results::shown(f.name, f.value, f.u.value_or(NAN), plane, group);
  if (!f.not_determined.empty()) return {s.label, "not determined", ""};  // why: in the notes
  return {s.label, s.value, s.unit};
}

// Whether the group holds a line shown as its amplitude and phase (results::line_of_part).
bool holds_a_line(const results::FigureGroup& items) {
  for (const results::Figure& f : items.figures)
    if (const auto line = results::line_of_part(f.name); line && f.name == line->sine && items.find(line->amplitude))
      return true;
  return false;
}

// The group's title for people ("lai3" -> "Lai's third-order model").
std::string group_title(const std::string& group) {
  if (group == results::lai_S_x.group) return "Lai's third-order model";
  if (group == results::backlash.group) return "ballbar diagnostics";
  if (group == "beside") return "fitted beside the models' terms (what EXPLAIN found on the same runs; in no table)";
  return results::in_words(group);
}

// "a1_rad" -> "a1", "c0_plus_d1_rad" -> "c0 + d1": Lai's symbols, for a list.
std::string symbol(const std::string& name) {
  std::string s = results::split_unit(name).first;
  for (auto at = s.find("_plus_"); at != std::string::npos; at = s.find("_plus_")) s.replace(at, 6, " + ");
  return s;
}

std::string joined(const nlohmann::json& names, const char* sep = ", ") {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : sep) + symbol(n.get<std::string>());
  return out;
}

// " over a 220 deg arc, 1 gap": a run's data arc when not the full circle, and its dropouts.
std::string arc_and_gaps(const nlohmann::json& r) {
  std::string out;
  const double arc = number_or(r, "data_arc_deg", 360.0);
  if (arc < 359.0) out += " over a " + format_fixed(arc, 0) + " deg arc";
  const int gaps = r.value("gaps", 0);
  if (gaps > 0) out += (out.empty() ? ", " : "; ") + std::to_string(gaps) + (gaps == 1 ? " gap" : " gaps");
  return out;
}

// One line per run: its set-up and G.
void print_runs(const nlohmann::json& runs) {
  std::vector<std::vector<std::string>> rows;
  int k = 0;
  for (const auto& r : runs)
    rows.push_back(
        {"run " + std::to_string(++k), "r " + significant_digits(number_or(r, "radius_mm", NAN), 6) + " mm",
         "h " + significant_digits(number_or(r, "height_mm", NAN), 6) + " mm", r.value("direction", "?"),
         format_fixed(number_or(r, "feed_mm_per_min", NAN), 0) + " mm/min",
         "G " + format_number(number_or(r, "circular_deviation_um", NAN), 3) + " \u00b5m" + arc_and_gaps(r)});
  std::cout << "runs:\n" << aligned_rows(rows, {});
}

// A run's test conditions in words, "not recorded" where the run's metadata does not say.
std::string conditions_text(const nlohmann::json& c) {
  const auto optional = [&](const char* key, const char* unit) {
    const nlohmann::json v = c.value(key, nlohmann::json("not recorded"));
    return v.is_number() ? significant_digits(v.get<double>(), 4) + unit : std::string("not recorded");
  };
  const double arc = number_or(c, "data_arc_deg", 360.0);
  const int gaps = c.value("gaps", 0);
  return "r " + significant_digits(number_or(c, "radius_mm", NAN), 6) + " mm, h " +
         significant_digits(number_or(c, "height_mm", NAN), 6) + " mm, " +
         format_fixed(number_or(c, "feed_mm_per_min", NAN), 0) + " mm/min, " + c.value("direction", "?") + ", " +
         (c.value("partial_arc", false) ? format_fixed(arc, 0) + " deg arc" : std::string("full circle")) + ", " +
         std::to_string(c.value("samples", 0)) + " samples every " +
         significant_digits(number_or(c, "spacing_deg", NAN), 4) + " deg, " +
         (gaps == 0 ? std::string("no gap") : std::to_string(gaps) + (gaps == 1 ? " gap" : " gaps")) + "; feed-in " +
         optional("feed_in_deg", " deg") + ", feed-out " + optional("feed_out_deg", " deg") + "; temperature " +
         optional("temperature_c", " \u00b0C");
}

// "ISO 230-4 circular deviation G 5.34 µm" for each of `names` the entry holds.
std::string figures_text(const nlohmann::json& entry, std::initializer_list<const results::Parameter*> names) {
  std::string out;
  for (const results::Parameter* p : names) {
    const std::string n = results::name(*p);
    if (!entry.contains(n)) continue;
    const results::Shown s = results::shown(n, number_or(entry[n], "value", NAN), NAN);
    out += (out.empty() ? "" : "; ") + s.label + " " + s.value + " " + s.unit;
  }
  return out;
}

// The standards' figures (docs/standards.md): per run, then per CCW/CW pair, each with what it is over.
void print_standards(const nlohmann::json& st) {
  if (!st.is_object() || st.value("runs", nlohmann::json::array()).empty()) return;
  namespace r = results;
  std::cout << "the standards' figures (docs/standards.md; a partial arc's are over its arc only):\n";
  for (const auto& run : st["runs"]) {
    std::cout << "  run " << run.value("run", 0) << ", over " << run.value("over", std::string("?")) << ": "
              << figures_text(run, {&r::iso_circular_deviation, &r::iso_radial_deviation_max,
                                    &r::iso_radial_deviation_min, &r::asme_circularity})
              << "\n    test conditions: " << conditions_text(run.value("conditions", nlohmann::json::object()))
              << "\n";
  }
  for (const auto& pair : st.value("pairs", nlohmann::json::array()))
    std::cout << "  runs " << pair.value("ccw_run", 0) << " (ccw) and " << pair.value("cw_run", 0) << " (cw), over "
              << pair.value("over", std::string("?")) << ": "
              << figures_text(pair, {&r::iso_circular_hysteresis, &r::iso_bidirectional_deviation, &r::asme_hysteresis,
                                     &r::asme_bidirectional_circularity})
              << "\n";
}

// A group's rows in the catalogue's order (Lai's offsets, scales, straightness, backlash ...), not the
// JSON's alphabetical one.
std::vector<std::vector<std::string>> group_rows(const results::FigureGroup& items, std::string_view plane, bool iso,
                                                 bool without_u = false) {
  std::vector<std::pair<double, std::vector<std::string>>> ranked;
  for (const results::Figure& f : items.figures) {
    if (f.name.starts_with("circular_") != iso) continue;
    // A line's sine and cosine parts are shown as its amplitude and phase (beside them in the JSON).
    if (const auto line = results::line_of_part(f.name); line && items.find(line->amplitude)) continue;
    if (!iso && !without_u && !f.u) continue;  // a searched or assumed value: searched_values()
    ranked.emplace_back(results::shown_order(f.name, items.name), shown_row(f, plane, items.name));
  }
  std::stable_sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::vector<std::string>> rows;
  for (auto& [at, row] : ranked) rows.push_back(std::move(row));
  return rows;
}

// The values a fit held at what a search chose or a default (a spike's decay and delay, a cyclic error
// not found): one line, apart from the fitted ones, since they have no uncertainty to show.
std::string searched_values(const results::FigureGroup& items, std::string_view plane) {
  std::string out;
  for (const results::Figure& f : items.figures) {
    if (f.name.starts_with("circular_") || f.u) continue;
    const auto row = shown_row(f, plane, items.name);
    out += (out.empty() ? "" : ", ") + row[0] + " " + row[1] + (row[2].empty() ? "" : " " + row[2]);
  }
  return out;
}

// A fit in one line: how well it fits, and what the runs cannot separate (the condition number and the
// solver's message stay in --json).
void print_fit(const nlohmann::json& fit) {
  if (!fit.is_object() || fit.value("n", 0) == 0) return;
  std::cout << "  fit to the " << fit.value("n", 0) << " points: " << format_number(number_or(fit, "rms_um", NAN), 2)
            << " \u00b5m rms\n";
  const nlohmann::json refused = fit.value("unidentifiable", nlohmann::json::array());
  if (!refused.empty())
    std::cout << "  not separable by these runs (not reported): " << joined(refused)
              << (fit.contains("combinations") ? "; --json gives the combinations they determine" : "") << "\n";
  for (const auto& why : fit.value("why", nlohmann::json::array()))
    std::cout << "    " << why.get<std::string>() << "\n";
}

// "What to fix first": each error's part of G, largest first, in words; the ones under 1 % of G in a line.
// `p`: the identification's record (results::Params::record).
void print_ranking(const nlohmann::json& p, std::string_view plane, double g_um) {
  const nlohmann::json ranking = p.value("ranking", nlohmann::json::array());
  if (ranking.empty()) return;
  const std::string model = p.value("ranking_model", std::string("?"));
  std::cout << "what to fix first (each error's part of the circular deviation"
            << (std::isfinite(g_um) ? " G = " + format_number(g_um, 3) + " \u00b5m" : std::string(" G")) << ", from "
            << (model == "lai3" ? "Lai's model" : "the " + model) << "):\n";
  const std::string group = model == "lai3" ? std::string(results::ranking_group) : model;
  std::vector<std::vector<std::string>> rows;
  std::string small;
  for (const auto& c : ranking) {
    const std::string label = results::label_of(c.value("name", std::string("?")), plane, group);
    const double um = number_or(c, "contribution_um", NAN),
                 percent = number_or(c, "percent_of_circular_deviation", NAN);
    if (std::isfinite(percent) && percent < negligible_percent) {
      small += (small.empty() ? "" : ", ") + label + " " + format_number(um, 2) + " \u00b5m";
      continue;
    }
    rows.push_back({label, format_number(um, 3) + " \u00b5m",
                    std::isfinite(percent) ? format_number(percent, 2) + " %" : std::string("\u2013")});
  }
  std::cout << aligned_rows(rows, {false, true, true});
  if (!small.empty()) std::cout << "  under 1 % of G each: " << small << "\n";
}

void print_dbb(const results::Params& p, std::string_view plane) {
  const nlohmann::json& record = p.record;
  if (record.contains("runs") && record["runs"].is_array() && !record["runs"].empty()) print_runs(record["runs"]);
  const results::FigureGroup none_in_diagnostics{std::string(results::diagnostics_group), {}};
  const results::FigureGroup none_in_lai3{std::string(results::lai3_group), {}};
  const results::FigureGroup* found = p.group(results::diagnostics_group);
  const results::FigureGroup& diagnostics = found ? *found : none_in_diagnostics;
  const auto iso = group_rows(diagnostics, plane, true);
  if (!iso.empty())
    std::cout << "ISO 230-4 circular test (the largest of the runs):\n" << aligned_rows(iso, {false, true});
  const auto diag = group_rows(diagnostics, plane, false);
  if (!diag.empty()) {
    std::cout << "ballbar diagnostics (value \u00b1 standard uncertainty):\n" << aligned_rows(diag, {false, true});
    if (const std::string held = searched_values(diagnostics, plane); !held.empty())
      std::cout << "  held at a searched or assumed value (no u): " << held << "\n";
    print_fit(record.value("diagnostics_fit", nlohmann::json::object()));
  }
  const results::FigureGroup* lai3 = p.group(results::lai3_group);
  const auto lai = group_rows(lai3 ? *lai3 : none_in_lai3, plane, false);
  if (!lai.empty()) {
    std::cout << "Lai's third-order model (value \u00b1 standard uncertainty):\n" << aligned_rows(lai, {false, true});
    print_fit(record.value("fit", nlohmann::json::object()));
  }
  print_standards(record.value("standards", nlohmann::json::object()));
  const results::Figure* g = diagnostics.find(results::name(results::circular_deviation));
  print_ranking(record, plane, g ? g->value : NAN);
}

}  // namespace

std::string aligned_rows(const std::vector<std::vector<std::string>>& rows, const std::vector<bool>& right,
                         std::string_view indent) {
  std::vector<std::size_t> width;
  for (const auto& row : rows)
    for (std::size_t c = 0; c + 1 < row.size(); ++c) {  // the last cell is not padded
      if (width.size() <= c) width.resize(c + 1, 0);
      width[c] = std::max(width[c], display_width(row[c]));
    }
  std::string out;
  for (const auto& row : rows) {
    std::string line(indent);
    for (std::size_t c = 0; c < row.size(); ++c) {
      const bool last = c + 1 == row.size();
      const std::size_t pad = last ? 0 : width[c] - display_width(row[c]);
      if (c > 0) line += "  ";
      if (c < right.size() && right[c] && !last) line += std::string(pad, ' ');
      line += row[c];
      if (!(c < right.size() && right[c]) && !last) line += std::string(pad, ' ');
    }
    while (!line.empty() && line.back() == ' ') line.pop_back();
    out += line + "\n";
  }
  return out;
}

void print_result(const results::Params& p) {
  const std::string plane = p.plane.empty() ? "xy" : p.plane;
  const bool dbb = p.group(results::lai3_group) != nullptr || p.record.contains("ranking");
  if (dbb) print_dbb(p, plane);
  // The groups by name, as the JSON orders them.
  std::vector<const results::FigureGroup*> groups;
  for (const results::FigureGroup& g : p.groups) groups.push_back(&g);
  std::stable_sort(groups.begin(), groups.end(), [](const auto* a, const auto* b) { return a->name < b->name; });
  for (const results::FigureGroup* g : groups) {
    if ((dbb && (g->name == results::diagnostics_group || g->name == results::lai3_group)) || g->figures.empty())
      continue;
    // Every value, those with no uncertainty of their own too (ISO 230-7's peaks-to-valleys as measured).
    std::cout << group_title(g->name) << ":\n" << aligned_rows(group_rows(*g, plane, false, true), {false, true});
    if (holds_a_line(*g)) std::cout << "  " << results::line_phase_reference << "\n";
  }
  const nlohmann::json& record = p.record;
  for (const auto& n : record.value("notes", nlohmann::json::array()))
    std::cout << "note: " << n.get<std::string>() << "\n";
  if (record.contains("wavelet") && record["wavelet"].contains("bands")) {  // the profile session's summary
    const auto& w = record["wavelet"];
    std::cout << "wavelet " << w.value("wavelet", "?") << ", " << w.value("level", 0) << " levels (dominant detail "
              << w.value("dominant_detail", "?") << "):";
    for (const auto& b : w["bands"])
      std::cout << " " << b.value("band", "?") << " "
                << format_number(b.contains("rms_um") ? number_or(b, "rms_um", NAN) : number_or(b, "form_um", NAN), 3)
                << " \u00b5m";
    std::cout << "\n";
  }
}

void print_planes_summary(const nlohmann::json& s) {
  std::cout << "the machine across its planes (" << joined(s.value("planes", nlohmann::json::array())) << "):\n";
  std::vector<std::vector<std::string>> rows;
  for (const char* group : {"squareness", "scale_mismatch"}) {
    const nlohmann::json items = s.value(group, nlohmann::json::object());
    for (const auto& [name, v] : items.items()) {
      // squareness_xz_urad: the plane is in the name
      const std::string bare = results::split_unit(name).first;
      const std::string plane = bare.substr(bare.size() - 2);
      rows.push_back(shown_row(name, v, plane, results::planes_group));
    }
  }
  for (const char* group : {"backlash", "scale"}) {
    const nlohmann::json items = s.value(group, nlohmann::json::object());
    for (const auto& [name, v] : items.items()) {
      std::vector<std::string> row = shown_row(name, v, "xy", results::planes_group);
      std::string from;
      for (const auto& f : v.value("from", nlohmann::json::array()))
        from +=
            (from.empty() ? "" : ", ") + f.value("plane", std::string("?")) + " " +
            results::shown(name, number_or(f, "value", NAN), number_or(f, "u", NAN), "xy", results::planes_group).value;
      row.push_back("from " + from + (v.value("consistent", true) ? "" : ": the planes DISAGREE"));
      rows.push_back(std::move(row));
    }
  }
  std::cout << aligned_rows(rows, {false, true});
  const nlohmann::json ranking = s.value("ranking", nlohmann::json::array());
  if (!ranking.empty()) {
    std::cout << "what to fix first across the machine (each error's part of the largest G, "
              << format_number(number_or(s, "circular_deviation_um", NAN), 3) << " \u00b5m):\n";
    std::vector<std::vector<std::string>> r;
    for (const auto& c : ranking) {
      const double percent = number_or(c, "percent_of_circular_deviation", NAN);
      if (std::isfinite(percent) && percent < negligible_percent) continue;
      const std::string plane = c.value("plane", std::string("xy"));
      r.push_back({plane, results::label_of(c.value("name", std::string("?")), plane, results::backlash.group),
                   format_number(number_or(c, "contribution_um", NAN), 3) + " \u00b5m",
                   std::isfinite(percent) ? format_number(percent, 2) + " %" : std::string("\u2013")});
    }
    std::cout << aligned_rows(r, {false, false, true, true});
  }
  for (const auto& n : s.value("notes", nlohmann::json::array())) std::cout << "note: " << n.get<std::string>() << "\n";
}

void print_params(const nlohmann::json& message) {
  const results::ResultHeader h = results::read_header(message);
  const results::Params p = results::params_from_json(message);
  const auto known = [](const std::string& text) { return text.empty() ? std::string("?") : text; };
  std::cout << "session " << known(h.session) << " (" << known(h.kind) << " on " << known(h.device) << "), model "
            << known(p.model) << "\n";
  // Several planes (the three-plane test): the first plane's result is the PARAMS' own, then each other
  // plane's, then the machine across them.
  const nlohmann::json planes = p.record.value("planes", nlohmann::json::object());
  const std::string first = p.plane.empty() ? "xy" : p.plane;
  if (!planes.empty()) std::cout << "plane " << first << ":\n";
  print_result(p);
  for (const auto& [name, id] : planes.items()) {
    if (name == first) continue;
    std::cout << "plane " << name << ":\n";
    if (id.contains("error")) {
      std::cout << "  not identified: " << id.value("error", std::string()) << "\n";
      continue;
    }
    print_result(results::params_from_json(id));
  }
  if (p.record.contains("summary")) print_planes_summary(p.record["summary"]);
  if (!p.incomplete.empty()) std::cout << "incomplete: " << p.incomplete << "\n";
  if (!h.recording.empty()) std::cout << "recording: " << h.recording << "\n";
  if (!h.recording_error.empty()) std::cout << "recording error: " << h.recording_error << "\n";
  for (const auto& f : h.derived) std::cout << "derived: " << f << "\n";
  print_instrument(message, std::cout);
}

void print_explanation(const results::Explanation& e) {
  const std::string model = e.model.empty() ? "?" : e.model;
  if (!e.not_analysed.empty()) {
    std::cout << "explanation (" << model << " model): not analysed: " << e.not_analysed << "\n";
    return;
  }
  std::cout << "explanation (" << model << " model): held-out rms " << format_number(e.baseline.heldout_rms_um, 3)
            << " \u00b5m -> " << format_number(e.final_fit.heldout_rms_um, 3) << " \u00b5m\n";
  for (const auto& f : e.findings) {
    std::cout << "  " << results::in_words(f.effect) << ":";
    std::string sep = " ";
    for (const auto& [name, v] : f.parameters) {
      if (std::isnan(v.value)) continue;
      const results::Shown s = results::shown(name, v.value, v.u);
      std::cout << sep << s.label << " " << s.value << (s.unit.empty() ? "" : " " + s.unit);
      sep = ", ";
    }
    std::cout << "\n    " << f.why << "\n";
  }
  // Largest first, against the yardstick (a DBB run's circular deviation G).
  std::vector<std::pair<double, std::string>> ranked;
  for (const auto& f : e.findings) {
    if (!std::isfinite(f.contribution_um)) continue;
    std::string line = results::in_words(f.effect) + " " + format_number(f.contribution_um, 3) + " \u00b5m";
    if (std::isfinite(f.percent_of_deviation)) line += " (" + format_number(f.percent_of_deviation, 2) + " %)";
    ranked.emplace_back(f.contribution_um, line);
  }
  std::stable_sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  if (!ranked.empty()) {
    std::cout << "  largest first";
    if (e.deviation)
      std::cout << " (of " << (e.deviation->name.empty() ? "the deviation" : e.deviation->name) << " "
                << format_number(e.deviation->value_um, 3) << " \u00b5m)";
    std::cout << ":";
    for (std::size_t k = 0; k < ranked.size(); ++k) std::cout << (k ? "; " : " ") << ranked[k].second;
    std::cout << "\n";
  }
  if (e.unexplained) std::cout << "  a structured residual is left that no effect of the library explains\n";
}

void throw_if_error_reply(const nlohmann::json& reply, bool json) {
  if (json && results::has_class(reply, results::MessageClass::error)) std::cout << reply.dump() << "\n" << std::flush;
  throw_if_error(reply);
}

namespace {

std::string number(const nlohmann::json& v) {
  if (!v.is_number()) return v.is_string() ? v.get<std::string>() : v.dump();
  std::ostringstream s;
  s << std::setprecision(6) << v.get<double>();
  return s.str();
}

std::string wall_clock_now() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  std::tm tm{};
  localtime_r(&ts.tv_sec, &tm);
  char buf[32];
  const std::size_t n = std::strftime(buf, sizeof(buf), "%H:%M:%S", &tm);
  std::snprintf(buf + n, sizeof(buf) - n, ".%03ld", ts.tv_nsec / 1'000'000);
  return buf;
}

}  // namespace

DisplayUnit display_unit(const std::string& si_unit, double first_value) {
  if (si_unit == "m") return std::abs(first_value) >= 1e-3 ? DisplayUnit{"mm", 1e3, 4} : DisplayUnit{"µm", 1e6, 3};
  if (si_unit == "rad") return {"arcsec", 1.0 / rad_per_arcsec, 2};
  return {si_unit == "1" ? std::string() : si_unit, 1.0, -1};
}

std::string watch_line(const nlohmann::json& m, const ChannelUnits& units, ChannelDisplay* display) {
  const std::string cls = m.value("class", "?");
  const std::optional<results::MessageClass> known = results::class_named(cls);
  std::ostringstream out;
  out << wall_clock_now() << " " << std::left << std::setw(7) << cls << std::right;
  // A value with its unit: as the daemon sent it (SI) without `display`, else in the channel's display unit.
  const auto value_of = [&](const std::string& device, const std::string& channel, const nlohmann::json& v) {
    const auto it = units.find(device + "/" + channel);
    const std::string si_unit = it == units.end() ? std::string() : it->second;
    if (display == nullptr || !v.is_number())
      return number(v) + (si_unit.empty() || si_unit == "1" ? "" : " " + si_unit);
    auto shown = display->find(device + "/" + channel);
    if (shown == display->end())
      shown = display->emplace(device + "/" + channel, display_unit(si_unit, v.get<double>())).first;
    const DisplayUnit& d = shown->second;
    std::ostringstream s;
    if (d.decimals >= 0)
      s << std::fixed << std::setprecision(d.decimals) << v.get<double>() * d.per_si;
    else
      s << number(v.get<double>() * d.per_si);
    return s.str() + (d.unit.empty() ? "" : " " + d.unit);
  };
  if (known == results::MessageClass::sample) {
    const std::string device = m.value("device", "?");
    out << " " << device << " seq " << m.value("seq", nlohmann::json(0)).dump();
    const nlohmann::json values = m.value("values", nlohmann::json::object());
    for (const auto& [name, v] : values.items()) {
      out << "  " << name << "=" << value_of(device, name, v);
    }
    const nlohmann::json denoised = m.value("denoised", nlohmann::json::object());
    const nlohmann::json denoised_values = denoised.value("values", nlohmann::json::object());
    for (const auto& [name, v] : denoised_values.items()) {
      out << "  " << name << "(denoised, seq " << denoised.value("seq", nlohmann::json(0)).dump()
          << ")=" << value_of(device, name, v);
    }
    if (m.contains("flags")) out << "  flags=" << m["flags"].dump();
  } else if (known == results::MessageClass::status) {
    const nlohmann::json devices = m.value("devices", nlohmann::json::array());
    for (const auto& d : devices) {
      out << " " << d.value("name", "?") << ":" << d.value("state", "?");
      const nlohmann::json c = d.value("counters", nlohmann::json::object());
      const std::uint64_t overruns = c.value("overruns", std::uint64_t{0});
      if (overruns != 0) out << "(overruns " << overruns << ")";
    }
    const nlohmann::json sessions = m.value("sessions", nlohmann::json::array());
    for (const auto& s : sessions) {
      if (s.value("state", "") != "running" && s.value("state", "") != "finishing") continue;
      out << "  session " << s.value("session", "?") << " " << s.value("progress", s.value("state", "?"));
      if (s.contains("recording_error")) out << " [recording error: " << s.value("recording_error", "") << "]";
    }
  } else if (known == results::MessageClass::params) {
    out << " " << m.value("session", "?");
    try {
      const results::Params p = results::params_from_json(m);
      out << " (" << (p.model.empty() ? "?" : p.model) << ")";
      for (const results::FigureGroup& g : p.groups)
        for (const results::Figure& f : g.figures) {
          // null (NaN here) as the message says it; a value with its u rounded to it
          out << "  " << f.name << "=";
          if (std::isnan(f.value))
            out << "null";
          else if (f.u && !std::isnan(*f.u))
            out << with_uncertainty(f.value, *f.u);
          else
            out << number(f.value);
        }
    } catch (const results::ParamsFormatError& error) {
      out << " (not a PARAMS: " << error.what() << ")";
    }
    if (m.contains("recording_error")) out << "  [recording error: " << m.value("recording_error", "") << "]";
  } else if (known == results::MessageClass::explain) {
    out << " " << m.value("session", "?");
    try {
      const results::Explanation e = results::explanation_from_json(m);
      out << " (" << (e.model.empty() ? "?" : e.model) << ")";
      if (!e.not_analysed.empty()) {
        out << " not analysed: " << e.not_analysed;
      } else {
        const auto rms = [](double v) { return std::isfinite(v) ? number(v) : std::string("?"); };
        out << " held-out rms " << rms(e.baseline.heldout_rms_um) << " um -> " << rms(e.final_fit.heldout_rms_um)
            << " um; findings:";
        if (e.findings.empty()) out << " none";
        for (const auto& f : e.findings) out << " " << f.effect;
        if (e.unexplained) out << "; a structured residual is left";
      }
    } catch (const results::ExplanationFormatError& error) {
      out << " (not an explanation: " << error.what() << ")";
    }
  } else if (known == results::MessageClass::event) {
    out << " " << m.value("device", "") << " " << m.value("event", "?");
    if (m.contains("session")) out << " " << m.value("session", "");
    if (m.contains("reason")) out << ": " << m.value("reason", "");
    if (m.contains("file")) out << ": " << m.value("file", "");
  } else if (known == results::MessageClass::error) {
    out << " " << m.value("message", "?");
  } else {
    out << " " << m.dump();  // a class of a later protocol minor version
  }
  return out.str();
}

}  // namespace guideway::cli
