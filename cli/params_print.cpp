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

std::vector<std::string> shown_row(const std::string& name, const results::DbbEstimate& e, std::string_view plane,
                                   std::string_view group) {
  const results::Shown s = results::shown(name, e.value, e.u.value_or(NAN), plane, group);
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

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + symbol(n);
  return out;
}

// A text as stated, "?" where the result leaves it empty.
std::string stated(const std::string& text) { return text.empty() ? std::string("?") : text; }

// " over a 220 deg arc, 1 gap": a run's data arc when not the full circle, and its dropouts.
std::string arc_and_gaps(const results::DbbRunSummary& r) {
  std::string out;
  const double arc = r.data_arc_deg.value_or(360.0);
  if (arc < 359.0) out += " over a " + format_fixed(arc, 0) + " deg arc";
  if (r.gaps > 0) out += (out.empty() ? ", " : "; ") + std::to_string(r.gaps) + (r.gaps == 1 ? " gap" : " gaps");
  return out;
}

// One line per run: its set-up and G.
void print_runs(const std::vector<results::DbbRunSummary>& runs) {
  std::vector<std::vector<std::string>> rows;
  int k = 0;
  for (const auto& r : runs)
    rows.push_back({"run " + std::to_string(++k), "r " + significant_digits(r.radius_mm, 6) + " mm",
                    "h " + significant_digits(r.height_mm, 6) + " mm", stated(r.direction),
                    format_fixed(r.feed_mm_per_min, 0) + " mm/min",
                    "G " + format_number(r.circular_deviation_um, 3) + " \u00b5m" + arc_and_gaps(r)});
  std::cout << "runs:\n" << aligned_rows(rows, {});
}

// A run's test conditions in words, "not recorded" where the run's metadata does not say.
std::string conditions_text(const results::DbbTestConditions& c) {
  const auto optional = [](const std::optional<double>& v, const char* unit) {
    return v ? significant_digits(*v, 4) + unit : std::string("not recorded");
  };
  return "r " + significant_digits(c.radius_mm, 6) + " mm, h " + significant_digits(c.height_mm, 6) + " mm, " +
         format_fixed(c.feed_mm_per_min, 0) + " mm/min, " + stated(c.direction) + ", " +
         (c.partial_arc ? format_fixed(c.data_arc_deg, 0) + " deg arc" : std::string("full circle")) + ", " +
         std::to_string(c.samples) + " samples every " + significant_digits(c.spacing_deg, 4) + " deg, " +
         (c.gaps == 0 ? std::string("no gap") : std::to_string(c.gaps) + (c.gaps == 1 ? " gap" : " gaps")) +
         "; feed-in " + optional(c.feed_in_deg, " deg") + ", feed-out " + optional(c.feed_out_deg, " deg") +
         "; temperature " + optional(c.temperature_c, " \u00b0C");
}

// "ISO 230-4 circular deviation G 5.34 µm" for each figure, by its catalogue entry.
std::string figures_text(std::initializer_list<std::pair<const results::Parameter*, double>> figures) {
  std::string out;
  for (const auto& [entry, value] : figures) {
    const results::Shown s = results::shown(results::name(*entry), value, NAN);
    out += (out.empty() ? "" : "; ") + s.label + " " + s.value + " " + s.unit;
  }
  return out;
}

// The standards' figures (docs/standards.md): per run, then per CCW/CW pair, each with what it is over.
void print_standards(const results::DbbStandards& st) {
  if (st.runs.empty()) return;
  namespace r = results;
  std::cout << "the standards' figures (docs/standards.md; a partial arc's are over its arc only):\n";
  for (const auto& run : st.runs) {
    std::cout << "  run " << run.run << ", over " << stated(run.over) << ": "
              << figures_text({{&r::iso_circular_deviation, run.iso_circular_deviation_um},
                               {&r::iso_radial_deviation_max, run.iso_radial_deviation_max_um},
                               {&r::iso_radial_deviation_min, run.iso_radial_deviation_min_um},
                               {&r::asme_circularity, run.asme_circularity_um}})
              << "\n    test conditions: " << conditions_text(run.conditions) << "\n";
  }
  for (const auto& pair : st.pairs)
    std::cout << "  runs " << pair.ccw_run << " (ccw) and " << pair.cw_run << " (cw), over " << stated(pair.over)
              << ": "
              << figures_text({{&r::iso_circular_hysteresis, pair.iso_circular_hysteresis_um},
                               {&r::iso_bidirectional_deviation, pair.iso_bidirectional_deviation_um},
                               {&r::asme_hysteresis, pair.asme_hysteresis_um},
                               {&r::asme_bidirectional_circularity, pair.asme_bidirectional_circularity_um}})
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
void print_fit(const results::DbbFit& fit) {
  if (fit.n == 0) return;
  std::cout << "  fit to the " << fit.n << " points: " << format_number(fit.rms_um, 2) << " \u00b5m rms\n";
  if (!fit.unidentifiable.empty())
    std::cout << "  not separable by these runs (not reported): " << joined(fit.unidentifiable)
              << (fit.combinations.empty() ? "" : "; --json gives the combinations they determine") << "\n";
  for (const std::string& why : fit.why) std::cout << "    " << why << "\n";
}

// "What to fix first": each error's part of G, largest first, in words; the ones under 1 % of G in a line.
void print_ranking(const results::DbbRecord& record, std::string_view plane, double g_um) {
  if (record.ranking.empty()) return;
  const std::string model = stated(record.ranking_model);
  std::cout << "what to fix first (each error's part of the circular deviation"
            << (std::isfinite(g_um) ? " G = " + format_number(g_um, 3) + " \u00b5m" : std::string(" G")) << ", from "
            << (model == "lai3" ? "Lai's model" : "the " + model) << "):\n";
  const std::string group = model == "lai3" ? std::string(results::ranking_group) : model;
  std::vector<std::vector<std::string>> rows;
  std::string small;
  for (const auto& c : record.ranking) {
    const std::string label = results::label_of(stated(c.name), plane, group);
    const double um = c.contribution_um, percent = c.percent_of_circular_deviation;
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
  const results::DbbRecord none;
  const results::DbbRecord& record = p.dbb ? *p.dbb : none;
  if (!record.runs.empty()) print_runs(record.runs);
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
    print_fit(record.diagnostics_fit);
  }
  const results::FigureGroup* lai3 = p.group(results::lai3_group);
  const auto lai = group_rows(lai3 ? *lai3 : none_in_lai3, plane, false);
  if (!lai.empty()) {
    std::cout << "Lai's third-order model (value \u00b1 standard uncertainty):\n" << aligned_rows(lai, {false, true});
    print_fit(record.fit);
  }
  print_standards(record.standards);
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
  const bool dbb = p.group(results::lai3_group) != nullptr || p.dbb;
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
  if (p.dbb)
    for (const std::string& n : p.dbb->notes) std::cout << "note: " << n << "\n";
  if (p.wavelet) {  // the profile session's summary
    const results::WaveletSummary& w = *p.wavelet;
    std::cout << "wavelet " << stated(w.wavelet) << ", " << w.level << " levels (dominant detail "
              << stated(w.dominant_detail) << "):";
    for (const results::WaveletBand& b : w.bands)
      std::cout << " " << stated(b.band) << " " << format_number(b.rms_um ? *b.rms_um : b.form_um.value_or(NAN), 3)
                << " \u00b5m";
    std::cout << "\n";
  }
}

void print_planes_summary(const results::DbbPlanesSummary& s) {
  std::cout << "the machine across its planes (" << joined(s.planes) << "):\n";
  std::vector<std::vector<std::string>> rows;
  for (const auto* items : {&s.squareness, &s.scale_mismatch})
    for (const auto& [name, v] : *items) {
      // squareness_xz_urad: the plane is in the name
      const std::string bare = results::split_unit(name).first;
      const std::string plane = bare.substr(bare.size() - 2);
      rows.push_back(shown_row(name, v, plane, results::planes_group));
    }
  for (const auto* items : {&s.backlash, &s.scale})
    for (const auto& [name, v] : *items) {
      std::vector<std::string> row = shown_row(name, v.estimate, "xy", results::planes_group);
      std::string from;
      for (const auto& [plane, f] : v.from)
        from += (from.empty() ? "" : ", ") + stated(plane) + " " +
                results::shown(name, f.value, f.u.value_or(NAN), "xy", results::planes_group).value;
      row.push_back("from " + from + (v.consistent ? "" : ": the planes DISAGREE"));
      rows.push_back(std::move(row));
    }
  std::cout << aligned_rows(rows, {false, true});
  if (!s.ranking.empty()) {
    std::cout << "what to fix first across the machine (each error's part of the largest G, "
              << format_number(s.circular_deviation_um, 3) << " \u00b5m):\n";
    std::vector<std::vector<std::string>> r;
    for (const auto& c : s.ranking) {
      const double percent = c.percent_of_circular_deviation;
      if (std::isfinite(percent) && percent < negligible_percent) continue;
      const std::string plane = c.plane.empty() ? "xy" : c.plane;
      r.push_back({plane, results::label_of(stated(c.name), plane, results::backlash.group),
                   format_number(c.contribution_um, 3) + " \u00b5m",
                   std::isfinite(percent) ? format_number(percent, 2) + " %" : std::string("\u2013")});
    }
    std::cout << aligned_rows(r, {false, false, true, true});
  }
  for (const std::string& n : s.notes) std::cout << "note: " << n << "\n";
}

std::string session_line(const results::ResultHeader& h) {
  return "session " + stated(h.session) + " (" + stated(h.kind) + " on " + stated(h.device) + ")";
}

void print_params(const nlohmann::json& message) {
  const results::ResultHeader h = results::read_header(message);
  const results::Params p = results::params_from_json(message);
  std::cout << session_line(h) << ", model " << stated(p.model) << "\n";
  // Several planes (the three-plane test): the first plane's result is the PARAMS' own, then each other
  // plane's, then the machine across them.
  const std::string first = p.plane.empty() ? "xy" : p.plane;
  if (!p.planes.empty()) std::cout << "plane " << first << ":\n";
  print_result(p);
  for (const auto& [name, plane] : p.planes) {
    if (name == first) continue;
    std::cout << "plane " << name << ":\n";
    if (!plane.params) {
      std::cout << "  not identified: " << plane.error << "\n";
      continue;
    }
    print_result(*plane.params);
  }
  if (p.dbb && p.dbb->summary) print_planes_summary(*p.dbb->summary);
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
