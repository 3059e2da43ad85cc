// DBB runs: Lai third-order + ballbar diagnostics (models/dbb), polar plots per set-up.
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>
#include <tuple>

#include "formats/dbb_run.hpp"
#include "models/dbb/identify.hpp"
#include "models/dbb/three_planes.hpp"
#include "models/explain/dbb_checked.hpp"
#include "report/html.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"
#include "results/parameters.hpp"
#include "results/session_kinds.hpp"

namespace guideway::report {

namespace {

// Below this part of G an error is not drawn in the ranking; the table lists it in one row with the others.
constexpr double negligible_percent = 1.0;
constexpr std::size_t most_bars = 10;

// Each run's reading about its own least-squares circle (ISO 230-4): what its polar plot draws, its G,
// and the circle itself (mean radius change, centre).
std::vector<models::dbb::CircleFit> circles_of(const std::vector<formats::DbbRun>& runs) {
  std::vector<models::dbb::CircleFit> out;
  for (const auto& r : runs) {
    std::vector<double> um(r.dL_m.size());
    std::transform(r.dL_m.begin(), r.dL_m.end(), um.begin(), [](double d) { return d * 1e6; });
    out.push_back(models::dbb::least_squares_circle(r.angle_rad, um));
  }
  return out;
}

double range_of(const std::vector<double>& v) {
  if (v.empty()) return NAN;
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  return *hi - *lo;
}

std::string signed_um(double v) { return (v > 0 ? "+" : "") + format_number(v, 3); }

// The estimates as people read them: label in words, value ± u rounded to u, the unit it is shown in. A term
// that contradicts EXPLAIN's value of it on the same runs (`explain`) is "not determined", with both values,
// as `identify dbb` shows it.
Table estimates_table(const std::string& caption, const std::vector<models::dbb::Estimate>& list,
                      std::string_view plane, std::string_view group,
                      const std::vector<models::dbb::Estimate>& explain = {}) {
  Table t{caption, {"quantity", "value \u00b1 standard uncertainty", "unit"}, {}};
  t.text_columns = {2};
  for (const auto& e : list) {
    const results::Shown s = results::shown(e.name, e.value, e.fitted ? e.u : NAN, plane, group, 4);
    const auto other = std::find_if(explain.begin(), explain.end(), [&](const auto& x) { return x.name == e.name; });
    if (e.fitted && other != explain.end() && !models::explain::contradiction(e, explain).empty()) {
      const results::Shown theirs = results::shown(e.name, other->value, other->u, plane, group, 4);
      t.rows.push_back({html_escape(s.label),
                        html_escape("not determined: " + s.value + " here, EXPLAIN " + theirs.value),
                        html_escape(s.unit)});
      continue;
    }
    t.rows.push_back({html_escape(s.label), html_escape(s.value), html_escape(s.unit)});
  }
  return t;
}

// One polar plot per set-up (radius, height, plane), its runs overlaid (CCW blue, CW orange): each run's
// deviation about its own least-squares circle, magnified so the largest fills the plot, as a ballbar's
// software draws it; the circles' mean radius and centre are stated beside it.
void setup_plots(std::ostringstream& body, const std::vector<formats::DbbRun>& runs,
                 const std::vector<models::dbb::CircleFit>& circles) {
  std::map<std::tuple<double, double, std::string>, std::vector<std::size_t>> setups;
  for (std::size_t i = 0; i < runs.size(); ++i)
    setups[{std::round(runs[i].radius_m * 1e6) / 1e3, std::round(runs[i].height_m * 1e6) / 1e3, runs[i].plane}]
        .push_back(i);
  for (const auto& [key, members] : setups) {
    const auto& [radius_mm, height_mm, plane] = key;
    PolarPlot plot;
    plot.title = "DBB r = " + significant_digits(radius_mm, 6) + " mm, h = " + significant_digits(height_mm, 6) +
                 " mm, " + plane + " plane";
    plot.axis_a = std::string(1, static_cast<char>(std::toupper(plane[0])));
    plot.axis_b = std::string(1, static_cast<char>(std::toupper(plane[1])));
    plot.quantity = "deviation";
    plot.zero_ring = "least-squares circle";
    bool have_ccw = false, have_cw = false;
    std::size_t extra = 2;  // further runs of one direction take the next palette colours
    std::ostringstream circles_text;
    for (std::size_t i : members) {
      const auto& r = runs[i];
      const auto& c = circles[i];
      PolarSeries s;
      const bool is_ccw = r.direction == formats::DbbDirection::ccw;
      const std::string run =
          std::string(is_ccw ? "CCW" : "CW") + " " + format_number(r.feed_m_per_s * 60000, 4) + " mm/min";
      // A partial arc's G is over its data arc (ISO 230-4 on a partial arc): the legend says so.
      const std::string arc =
          formats::dbb_run_full_circle(r)
              ? std::string()
              : " over " + format_fixed(formats::dbb_run_arc_rad(r) * 180 / 3.141592653589793, 0) + "\u00b0";
      s.label = run + ", G = " + format_number(range_of(c.deviation_um), 3) + " \u00b5m" + arc;
      bool& have = is_ccw ? have_ccw : have_cw;
      s.color = palette(have ? extra++ : (is_ccw ? 0 : 1));
      have = true;
      s.angle_rad = r.angle_rad;
      s.deviation_um = c.deviation_um;
      plot.series.push_back(std::move(s));
      circles_text << (circles_text.tellp() > 0 ? "; " : "") << run << ": mean radius "
                   << format_fixed(r.radius_m * 1e3 + c.mean_um * 1e-3, 5) << " mm (\u0394L " << signed_um(c.mean_um)
                   << " \u00b5m), centre (" << signed_um(c.cos_um) << ", " << signed_um(c.sin_um) << ") \u00b5m";
    }
    std::ostringstream cap;
    cap << "Each run's bar reading about its own least-squares circle (the circle ISO 230-4's G is taken "
           "about), magnified: "
        << format_number(polar_um_per_div(plot), 3)
        << " \u00b5m per division, the bold ring the circle. The circles themselves: " << circles_text.str()
        << " (centre from the nominal, along +" << plot.axis_a << " and +" << plot.axis_b << ").";
    body << html_figure(render(plot), html_escape(cap.str()));
  }
}

// The ranking's entries of at least 1 % of G, and the others in one line.
struct Ranked {
  std::vector<std::pair<std::string, const models::dbb::Contribution*>> shown;
  std::string small;  // "servo mismatch 0.020 µm, ..."
};

Ranked ranked(const models::dbb::Identification& id) {
  Ranked out;
  const std::string_view group =
      id.ranking_model == "lai3" ? results::ranking_group : std::string_view(id.ranking_model);
  for (const auto& c : id.ranking) {
    const std::string label = results::label_of(c.name, id.plane, group);
    if (std::isfinite(c.percent) && c.percent < negligible_percent)
      out.small += (out.small.empty() ? "" : ", ") + label + " " + format_number(c.contribution_um, 2) + " \u00b5m";
    else
      out.shown.emplace_back(label, &c);
  }
  return out;
}

std::string ranking_source(const models::dbb::Identification& id) {
  return id.ranking_model == "diagnostics" ? "the ballbar diagnostics" : "Lai's model, its terms grouped by error";
}

// The errors ranked by their part of the circular deviation ("what to fix first"), as horizontal bars.
void ranking_chart(std::ostringstream& body, const models::dbb::Identification& id_result) {
  const Ranked r = ranked(id_result);
  if (r.shown.empty()) return;
  BarChart chart;
  chart.title = "What to fix first";
  chart.x_label = "error (from " + ranking_source(id_result) + ")";
  chart.width = 640;
  chart.y_label = "part of G / \u00b5m";
  chart.horizontal = true;
  BarSeries part{"range of its term about the least-squares circle", {}, palette(2)};
  for (std::size_t k = 0; k < r.shown.size() && k < most_bars; ++k) {
    chart.categories.push_back(r.shown[k].first);
    part.values.push_back(r.shown[k].second->contribution_um);
  }
  chart.series = {part};
  std::ostringstream cap;
  cap << "The identified errors by their part of the circular deviation G: the range of each one's fitted term "
         "about a run's least-squares circle (as G is the reading's), the largest over the runs, from "
      << ranking_source(id_result) << "; the set-up's centre offset is not ranked. Terms partly cancel, so the "
      << "parts need not add up to G.";
  if (r.shown.size() > most_bars) cap << " " << r.shown.size() - most_bars << " more are in the table below.";
  if (!r.small.empty()) cap << " Under 1 % of G each, not drawn: " << r.small << ".";
  body << html_figure(render(chart), html_escape(cap.str()));
}

void runs_table(std::ostringstream& body, const models::dbb::Identification& id_result,
                const std::vector<models::dbb::CircleFit>& circles) {
  Table runs_t{"Runs",
               {"file", "r / mm", "h / mm", "direction", "feed / (mm/min)", "points", "mean \u0394L / \u00b5m",
                "G (ISO 230-4) / \u00b5m", "residual rms / \u00b5m"},
               {}};
  runs_t.text_columns = {3};
  for (std::size_t k = 0; k < id_result.runs.size(); ++k) {
    const auto& r = id_result.runs[k];
    runs_t.rows.push_back({html_escape(base_name(r.source)), significant_digits(r.radius_mm, 6),
                           significant_digits(r.height_mm, 6), html_escape(r.direction),
                           format_fixed(r.feed_mm_per_min, 0), std::to_string(r.n),
                           k < circles.size() ? format_fixed(circles[k].mean_um, 2) : "&ndash;",
                           format_fixed(r.circular_deviation_um, 2), format_fixed(r.residual_rms_um, 3)});
  }
  body << html_table(runs_t);
}

// Runs traced with compensation loaded (`compensation = after`, guideway compensate --verify) whose reversal
// spikes are negative: an axis turning back early, which is the tables' backlash step, not stiction
// (models::compensation::spike_from_backlash_step, docs/compensation.md).
void compensated_spikes_note(std::ostringstream& body, const std::vector<formats::DbbRun>& runs,
                             const models::dbb::Identification& id_result) {
  const auto after = [](const formats::DbbRun& r) {
    const auto f = r.metadata.find("compensation");
    return f != r.metadata.end() && f->second != "before";
  };
  if (runs.empty() || !std::all_of(runs.begin(), runs.end(), after)) return;
  std::string spikes;
  for (int axis = 0; axis < 2; ++axis)
    for (const auto& e : id_result.diagnostics)
      if (e.name == results::name(results::reversal_spike, id_result.plane, axis) && e.fitted && std::isfinite(e.u) &&
          e.value < -2 * e.u)
        spikes += (spikes.empty() ? "" : " and ") + results::label_of(e.name, id_result.plane);
  if (spikes.empty()) return;
  body << html_note("These runs were traced with the compensation loaded. Their " + spikes +
                    " are negative, an axis turning back early: the tables' backlash step, which the controller "
                    "takes at the commanded reversal while the drive still lags its command, not stiction. No table "
                    "removes it; velocity feed-forward, or a reversal timing of the step, does (docs/compensation.md, "
                    "\"Reversal spikes after a backlash table\").");
}

// The standards' figures (docs/standards.md), each run's and each CCW/CW pair's with what it is over and
// the conditions it was measured under.
void standards_table(std::ostringstream& body, const models::dbb::Identification& id_result) {
  const models::dbb::StandardFigures& st = id_result.standards;
  if (st.runs.empty()) return;
  Table t{"The standards' figures (ISO 230-4, ASME B5.54; a partial arc's are over its arc only)",
          {"runs", "over", "G / \u00b5m", "F max / \u00b5m", "F min / \u00b5m", "H / \u00b5m", "G(b) / \u00b5m",
           "test conditions"},
          {}};
  t.text_columns = {0, 1, 7};
  const auto optional = [](const std::optional<double>& v, const char* unit) {
    return v ? significant_digits(*v, 4) + unit : std::string("not recorded");
  };
  const auto over = [](double arc_deg, bool partial) {
    return partial ? format_fixed(arc_deg, 0) + "\u00b0 arc" : std::string("full circle");
  };
  for (std::size_t k = 0; k < st.runs.size(); ++k) {
    const models::dbb::RunFigures& f = st.runs[k];
    const models::dbb::TestConditions& c = f.conditions;
    const std::string cond =
        "r " + significant_digits(c.radius_mm, 6) + " mm, h " + significant_digits(c.height_mm, 6) + " mm, " +
        format_fixed(c.feed_mm_per_min, 0) + " mm/min, " + c.direction + ", " + std::to_string(c.samples) +
        " samples every " + significant_digits(c.spacing_deg, 4) + "\u00b0, " + std::to_string(c.gaps) +
        " gaps, feed-in " + optional(c.feed_in_deg, "\u00b0") + ", feed-out " + optional(c.feed_out_deg, "\u00b0") +
        ", temperature " + optional(c.temperature_c, " \u00b0C");
    t.rows.push_back({"run " + std::to_string(k + 1) + " (" + html_escape(base_name(f.source)) + ")",
                      over(c.data_arc_deg, c.partial_arc), format_fixed(f.iso_circular_deviation_um, 2),
                      format_fixed(f.iso_radial_deviation_max_um, 2), format_fixed(f.iso_radial_deviation_min_um, 2),
                      "&ndash;", "&ndash;", html_escape(cond)});
  }
  for (const models::dbb::PairFigures& p : st.pairs) {
    const bool partial = st.runs[p.ccw].conditions.partial_arc || st.runs[p.cw].conditions.partial_arc;
    t.rows.push_back({"runs " + std::to_string(p.ccw + 1) + " (ccw) and " + std::to_string(p.cw + 1) + " (cw)",
                      over(p.common_arc_deg, partial), "&ndash;", "&ndash;", "&ndash;",
                      format_fixed(p.iso_circular_hysteresis_um, 2), format_fixed(p.iso_bidirectional_deviation_um, 2),
                      "common least-squares circle"});
  }
  body << html_table(t);
  body << html_note(
      "ASME B5.54's circularity of one direction is G, its hysteresis H and its bidirectional circularity G(b), "
      "computed alike (docs/standards.md).");
}

// The ranking in words, the ISO 230-4 figures and the diagnostics (only when the runs gave any: the
// identification's note says why not).
void runs_and_diagnostics_tables(std::ostringstream& body, const models::dbb::Identification& id_result,
                                 const std::vector<models::dbb::Estimate>& explain) {
  const Ranked r = ranked(id_result);
  if (!r.shown.empty() || !r.small.empty()) {
    Table rank_t{"What to fix first (each error's part of the circular deviation G)",
                 {"error", "part of G / \u00b5m", "% of G"},
                 {}};
    for (const auto& [label, c] : r.shown)
      rank_t.rows.push_back({html_escape(label), format_number(c->contribution_um, 3),
                             std::isfinite(c->percent) ? format_number(c->percent, 2) : "&ndash;"});
    if (!r.shown.empty()) body << html_table(rank_t);
    // With bars drawn, their caption names the ones under 1 % already.
    if (!r.small.empty() && r.shown.empty()) body << "<p>Under 1 % of G each: " << html_escape(r.small) << ".</p>";
  }
  for (const auto& n : id_result.notes) body << html_note(n);
  std::vector<models::dbb::Estimate> iso, diag;
  for (const auto& e : id_result.diagnostics) (e.name.rfind("circular_", 0) == 0 ? iso : diag).push_back(e);
  Table iso_t{"ISO 230-4 circular test figures", {"quantity", "value", "unit", "what it is"}, {}};
  iso_t.text_columns = {2, 3};
  for (const auto& e : iso) {
    const results::Shown s = results::shown(e.name, e.value, NAN, id_result.plane);
    const results::Parameter* p = results::find_parameter(e.name);
    iso_t.rows.push_back(
        {html_escape(s.label), format_fixed(e.value, 2), html_escape(s.unit), p ? html_escape(p->meaning) : ""});
  }
  if (iso.size() < 2)
    iso_t.rows.push_back(
        {html_escape(results::circular_hysteresis.label), "&ndash;", "", "needs a CCW and a CW run of one set-up"});
  body << html_table(iso_t);
  const auto& df = id_result.diagnostics_fit;
  if (diag.empty()) {
    const bool said = std::any_of(id_result.notes.begin(), id_result.notes.end(),
                                  [](const std::string& n) { return n.find("diagnostics") != std::string::npos; });
    if (!said)
      body << html_note("No ballbar diagnostics: they need in-plane (h = 0) runs in both directions of one set-up.");
    return;
  }
  // Values held at a searched or assumed value have no u: one line under the table, as the CLI prints them,
  // not rows among the measured ones.
  std::vector<models::dbb::Estimate> fitted, held;
  for (const auto& e : diag) (e.fitted && std::isfinite(e.u) ? fitted : held).push_back(e);
  body << html_table(estimates_table("Ballbar diagnostics", fitted, id_result.plane, results::backlash.group, explain));
  if (!held.empty()) {
    std::string line;
    for (const auto& e : held) {
      const results::Shown s = results::shown(e.name, e.value, NAN, id_result.plane, results::backlash.group, 4);
      line += (line.empty() ? "" : ", ") + s.label + " " + s.value + (s.unit.empty() ? "" : " " + s.unit);
    }
    body << "<p>Held at a searched or assumed value (no u): " << html_escape(line) << ".</p>";
  }
  if (df.n > 0)
    body << "<p>Diagnostics fit: rms " << format_number(df.rms_um, 2) << " \u00b5m over " << df.n << " points.</p>";
  if (!df.unidentifiable.empty()) body << html_note("Diagnostics not separable by these runs: " + df.message);
}

// What EXPLAIN found on the same runs and the models do not hold, as fitted beside their terms.
// A line (a vibration, a cyclic error) is shown as its amplitude and phase, not its sine and cosine parts.
void beside_table(std::ostringstream& body, const models::explain::CheckedIdentification& checked) {
  if (checked.id.beside.empty()) return;
  std::string effects;
  for (const auto& e : checked.beside) effects += (effects.empty() ? "" : ", ") + results::in_words(e);
  const auto has = [&](const std::string& name) {
    return std::any_of(checked.id.beside.begin(), checked.id.beside.end(),
                       [&](const auto& e) { return e.name == name; });
  };
  std::vector<models::dbb::Estimate> shown;
  bool lines = false;
  for (const auto& e : checked.id.beside) {
    const auto line = results::line_of_part(e.name);
    if (line && has(line->amplitude)) {
      lines = true;
      continue;
    }
    shown.push_back(e);
  }
  body << html_table(estimates_table(
      "Fitted beside the models' terms: what EXPLAIN found on the same runs (" + effects + "), in no table", shown,
      checked.id.plane, {}));
  if (lines) body << "<p>" << html_escape("A line's " + std::string(results::line_phase_reference) + ".") << "</p>";
}

// Lai's symbol of a reported name: "c0_plus_d1_rad" -> "c0 + d1".
std::string lai_symbol(const std::string& name) {
  std::string s = results::split_unit(name).first;
  for (auto at = s.find("_plus_"); at != std::string::npos; at = s.find("_plus_")) s.replace(at, 6, " + ");
  return s;
}

// Lai's model: its parameters, the fit and what the patterns could not separate.
void lai_tables(std::ostringstream& body, const models::dbb::Identification& id_result,
                const std::vector<models::dbb::Estimate>& explain) {
  body << html_table(estimates_table("Lai, Liao and Chieng's third-order model (Table 3 symbols in brackets)",
                                     id_result.lai3, id_result.plane, results::lai_S_x.group, explain));
  const auto& f = id_result.fit;
  body << "<p>Lai fit: rms " << format_number(f.rms_um, 2) << " \u00b5m over " << f.n << " points.</p>";
  if (f.unidentifiable.empty()) return;
  std::string names;
  for (const auto& n : f.unidentifiable) names += (names.empty() ? "" : ", ") + lai_symbol(n);
  body << html_note("Not separable by these patterns (refused, not reported): " + names +
                    ". A pattern with h > 0 at another radius separates them (docs/conventions.md).");
  if (!f.combinations.empty()) {
    Table c{"Combinations these patterns do determine (Lai's symbols, in the units they are reported in)",
            {"combination", "value \u00b1 u"}};
    for (const auto& k : f.combinations)
      c.rows.push_back({html_escape(k.expression), html_escape(with_uncertainty(k.value, k.u))});
    body << html_table(c);
  }
}

// Several planes: squareness and scale mismatch per plane, backlash and scale per axis from every plane that
// sees it (and whether they agree), and every plane's errors ranked together.
void planes_summary(std::ostringstream& body, const models::dbb::PlanesSummary& s) {
  body << "<h3>The machine across its planes</h3>";
  Table t{"Squareness and scale mismatch per plane; backlash and scale per axis from every plane that sees it",
          {"quantity", "value \u00b1 standard uncertainty", "unit", "from the planes"},
          {}};
  t.text_columns = {2, 3};
  const std::string group(results::planes_group);
  for (const auto* list : {&s.squareness, &s.scale_mismatch})
    for (const auto& e : *list) {
      const std::string bare = results::split_unit(e.name).first;
      const results::Shown v = results::shown(e.name, e.value, e.u, bare.substr(bare.size() - 2), group, 4);
      t.rows.push_back({html_escape(v.label), html_escape(v.value), html_escape(v.unit), ""});
    }
  for (const auto* list : {&s.backlash, &s.scale})
    for (const auto& f : *list) {
      const results::Shown v = results::shown(f.name, f.value, f.u, "xy", group, 4);
      std::string from;
      for (const auto& p : f.from)
        from += (from.empty() ? "" : ", ") + p.plane + " " + results::shown(f.name, p.value, p.u, "xy", group, 4).value;
      t.rows.push_back({html_escape(v.label), html_escape(v.value), html_escape(v.unit),
                        html_escape(from + (f.consistent ? "" : ": they disagree"))});
    }
  body << html_table(t);
  Table r{"What to fix first across the machine (each error's part of the largest G of the planes, " +
              format_number(s.circular_deviation_um, 3) + " \u00b5m)",
          {"plane", "error", "part of G / \u00b5m", "% of G"},
          {}};
  r.text_columns = {1};  // the error, in words
  for (const auto& c : s.ranking) {
    if (std::isfinite(c.percent) && c.percent < negligible_percent) continue;
    r.rows.push_back({html_escape(c.plane), html_escape(results::label_of(c.name, c.plane, results::backlash.group)),
                      format_number(c.contribution_um, 3),
                      std::isfinite(c.percent) ? format_number(c.percent, 2) : "&ndash;"});
  }
  body << html_table(r);
  for (const auto& n : s.notes) body << html_note(n);
}

// The session's identification of these runs (ReportOptions::identified), its runs named by their files as
// the rest of the section names them; nullopt when none is of this plane and these runs (as many, in the same
// directions, with as many points).
std::optional<models::explain::CheckedIdentification> session_identification(
    const std::vector<formats::DbbRun>& plane_runs, const std::vector<models::explain::CheckedIdentification>& given) {
  for (const auto& c : given) {
    const auto& runs = c.id.runs;
    if (c.id.plane != plane_runs.front().plane || runs.size() != plane_runs.size()) continue;
    bool same = true;
    for (std::size_t k = 0; k < runs.size() && same; ++k)
      same = runs[k].n == plane_runs[k].angle_rad.size() &&
             runs[k].direction == (plane_runs[k].direction == formats::DbbDirection::ccw ? "ccw" : "cw");
    if (!same) continue;
    models::explain::CheckedIdentification out = c;
    for (std::size_t k = 0; k < runs.size(); ++k) out.id.runs[k].source = plane_runs[k].source;
    for (std::size_t k = 0; k < out.id.standards.runs.size() && k < runs.size(); ++k)
      out.id.standards.runs[k].source = plane_runs[k].source;
    return out;
  }
  return std::nullopt;
}

}  // namespace

std::string dbb_section(const std::vector<std::string>& paths, const std::string& id,
                        const std::vector<models::explain::CheckedIdentification>& identified) {
  std::vector<formats::DbbRun> runs;
  for (const auto& p : paths) {
    try {
      runs.push_back(formats::read_dbb_run(p));
    } catch (const std::exception& e) {
      throw ReportError(e.what());
    }
  }
  std::ostringstream body;
  body << "<p>" << runs.size() << " circular test run(s): ";
  for (std::size_t i = 0; i < runs.size(); ++i)
    body << (i ? ", " : "") << "<code>" << html_escape(base_name(paths[i])) << "</code>";
  body << ". Identified together per plane (Lai, Liao and Chieng 1997 third-order model and the ballbar diagnostics; "
          "sign conventions in docs/conventions.md).</p>";

  const std::vector<models::dbb::CircleFit> circles = circles_of(runs);
  body << "<div class=\"side-by-side\">";
  setup_plots(body, runs, circles);
  body << "</div>";
  // Each plane identified on its own; with several, the machine across them after.
  std::vector<models::dbb::Identification> ids;
  const auto planes = models::dbb::runs_by_plane(runs);
  for (const auto& plane_runs : planes) {
    if (planes.size() > 1) body << "<h3>" << html_escape(plane_runs.front().plane) << " plane</h3>";
    std::vector<models::dbb::CircleFit> plane_circles;
    for (const auto& r : plane_runs)
      for (std::size_t k = 0; k < runs.size(); ++k)
        if (runs[k].source == r.source) plane_circles.push_back(circles[k]);
    // As `identify dbb` and the session's PARAMS: what EXPLAIN finds and the models do not hold is fitted
    // beside their terms. A session's report shows the session's own identification: what PARAMS published.
    std::optional<models::explain::CheckedIdentification> from_session = session_identification(plane_runs, identified);
    models::explain::CheckedIdentification checked;
    if (from_session) {
      checked = std::move(*from_session);
      body << "<p data-identified-by=\"session\">The values below are the session's identification, as its PARAMS "
              "published them (not identified again from these files).</p>";
    } else {
      try {
        checked = models::explain::identify_checked(plane_runs);
      } catch (const std::exception& e) {
        body << html_note("Identification refused: " + std::string(e.what()));
        continue;
      }
      body << "<p data-identified-by=\"files\">The values below are identified from these files.</p>";
    }
    ids.push_back(checked.id);
    const models::dbb::Identification& id_result = ids.back();
    ranking_chart(body, id_result);
    compensated_spikes_note(body, plane_runs, id_result);
    runs_table(body, id_result, plane_circles);
    runs_and_diagnostics_tables(body, id_result, checked.explain);
    beside_table(body, checked);
    standards_table(body, id_result);
    lai_tables(body, id_result, checked.explain);
  }
  if (ids.size() > 1) planes_summary(body, models::dbb::summarize_planes(ids));
  return html_section(std::string(results::dbb_kind.name), id, "Double ball bar: circular tests", body.str());
}

}  // namespace guideway::report
