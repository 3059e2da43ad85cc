// DBB runs: Lai third-order + ballbar diagnostics (models/dbb), polar plots per set-up.
#include <cmath>
#include <cstring>
#include <map>
#include <sstream>
#include <tuple>

#include "formats/dbb_run.hpp"
#include "models/dbb/identify.hpp"
#include "report/html.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"
#include "results/parameters.hpp"
#include "results/session_kinds.hpp"

namespace guideway::report {

namespace {

std::string estimate_cell(const models::dbb::Estimate& e) {
  return html_escape(e.fitted ? with_uncertainty(e.value, e.u) : format_number(e.value, 4));
}

Table estimates_table(const std::string& caption, const std::vector<models::dbb::Estimate>& list) {
  Table t{caption, {"quantity", "value \u00b1 standard uncertainty", "unit"}, {}};
  for (const auto& e : list) {
    const auto [name, unit] = results::split_unit(e.name);
    t.rows.push_back({html_escape(e.name), estimate_cell(e), html_escape(unit)});
  }
  return t;
}

// One polar plot per set-up (radius, height, plane), its runs overlaid: CCW blue, CW orange; each run's G
// in its label when the runs were identified.
void setup_plots(std::ostringstream& body, const std::vector<formats::DbbRun>& runs,
                 const models::dbb::Identification* id_result) {
  std::map<std::tuple<double, double, std::string>, std::vector<std::size_t>> setups;
  for (std::size_t i = 0; i < runs.size(); ++i)
    setups[{std::round(runs[i].radius_m * 1e6) / 1e3, std::round(runs[i].height_m * 1e6) / 1e3, runs[i].plane}]
        .push_back(i);
  for (const auto& [key, members] : setups) {
    const auto& [radius_mm, height_mm, plane] = key;
    PolarPlot plot;
    plot.title = "DBB r = " + format_number(radius_mm, 4) + " mm, h = " + format_number(height_mm, 4) + " mm, " +
                 plane + " plane";
    plot.axis_a = std::string(1, static_cast<char>(std::toupper(plane[0])));
    plot.axis_b = std::string(1, static_cast<char>(std::toupper(plane[1])));
    bool have_ccw = false, have_cw = false;
    std::size_t extra = 2;  // further runs of one direction take the next palette colours
    for (std::size_t i : members) {
      const auto& r = runs[i];
      PolarSeries s;
      const bool is_ccw = r.direction == formats::DbbDirection::ccw;
      s.label = std::string(is_ccw ? "CCW" : "CW") + " " + format_number(r.feed_m_per_s * 60000, 4) + " mm/min";
      if (id_result && i < id_result->runs.size())
        s.label += ", G = " + format_number(id_result->runs[i].circular_deviation_um, 3) + " \u00b5m";
      bool& have = is_ccw ? have_ccw : have_cw;
      s.color = palette(have ? extra++ : (is_ccw ? 0 : 1));
      have = true;
      s.angle_rad = r.angle_rad;
      s.deviation_um.reserve(r.dL_m.size());
      for (double d : r.dL_m) s.deviation_um.push_back(d * 1e6);
      plot.series.push_back(std::move(s));
    }
    std::ostringstream cap;
    cap << "Measured bar length change \u0394L (positive = longer) against the commanded angle, magnified: "
        << format_number(polar_um_per_div(plot), 3) << " \u00b5m per division around the nominal circle (bold). "
        << "G: ISO 230-4 circular deviation about each run's least-squares circle.";
    body << html_figure(render(plot), html_escape(cap.str()));
  }
}

// The errors ranked by their part of the circular deviation ("what to fix first"): the five largest.
void ranking_chart(std::ostringstream& body, const models::dbb::Identification& id_result) {
  BarChart chart;
  chart.title = "What to fix first";
  chart.x_label = "error (" + id_result.ranking_model + ")";
  chart.y_label = "part of G / \u00b5m";
  chart.width = 520;
  chart.height = 360;
  BarSeries part{"range about the least-squares circle", {}, palette(2)};
  // The five largest (all of them in the table below), named without their unit.
  for (std::size_t k = 0; k < id_result.ranking.size() && k < 5; ++k) {
    std::string name = id_result.ranking[k].name;
    for (const char* unit : {"_um", "_ppm", "_urad", "_ms"})
      if (name.size() > std::strlen(unit) && name.ends_with(unit)) name.resize(name.size() - std::strlen(unit));
    chart.categories.push_back(name);
    part.values.push_back(id_result.ranking[k].contribution_um);
  }
  chart.series = {part};
  std::ostringstream cap;
  cap << "The five identified errors with the largest part of the circular deviation: the range of each one's fitted "
         "term about the least-squares circle of a run (as G is the reading's), from the "
      << (id_result.ranking_model == "diagnostics" ? "ballbar diagnostics" : "Lai model's grouped terms")
      << "; the set-up's centre offset is not ranked. Terms partly cancel, so the parts need not add up to G.";
  body << html_figure(render(chart), html_escape(cap.str()));
}

// The runs, the ranking, the ISO 230-4 figures and the diagnostics.
void runs_and_diagnostics_tables(std::ostringstream& body, const models::dbb::Identification& id_result) {
  Table runs_t{"Runs",
               {"file", "r / mm", "h / mm", "direction", "feed / (mm/min)", "points", "G (ISO 230-4) / \u00b5m",
                "residual rms / \u00b5m"},
               {}};
  for (const auto& r : id_result.runs)
    runs_t.rows.push_back({html_escape(base_name(r.source)), format_number(r.radius_mm, 5),
                           format_number(r.height_mm, 5), html_escape(r.direction), format_number(r.feed_mm_per_min, 5),
                           std::to_string(r.n), format_fixed(r.circular_deviation_um, 3),
                           format_fixed(r.residual_rms_um, 3)});
  body << html_table(runs_t);
  if (!id_result.ranking.empty()) {
    Table rank_t{"What to fix first (each error's part of the circular deviation G)",
                 {"error", "part of G / \u00b5m", "% of G"},
                 {}};
    for (const auto& c : id_result.ranking)
      rank_t.rows.push_back({html_escape(c.name), format_fixed(c.contribution_um, 3),
                             std::isfinite(c.percent) ? format_fixed(c.percent, 1) : "&ndash;"});
    body << html_table(rank_t);
  }
  for (const auto& n : id_result.notes) body << html_note(n);
  std::vector<models::dbb::Estimate> iso, diag;
  for (const auto& e : id_result.diagnostics) (e.name.rfind("circular_", 0) == 0 ? iso : diag).push_back(e);
  Table iso_t{"ISO 230-4 circular test figures", {"quantity", "value", "unit"}, {}};
  for (const auto& e : iso) {
    const auto [name, unit] = results::split_unit(e.name);
    iso_t.rows.push_back({html_escape(e.name), format_fixed(e.value, 3), html_escape(unit)});
  }
  if (iso.size() < 2)
    iso_t.rows.push_back({"circular_hysteresis_um", "&ndash;", "needs a CCW and a CW run of one set-up"});
  body << html_table(iso_t);
  body << html_table(estimates_table("Ballbar diagnostics", diag));
  const auto& df = id_result.diagnostics_fit;
  body << "<p>Diagnostics fit: rms " << format_fixed(df.rms_um, 4) << " \u00b5m over " << df.n
       << " points, condition number " << format_number(df.condition_number, 3) << ".</p>";
  if (!df.unidentifiable.empty()) body << html_note("Diagnostics not separable by these runs: " + df.message);
}

// Lai's model: its parameters, the fit and what the patterns could not separate.
void lai_tables(std::ostringstream& body, const models::dbb::Identification& id_result) {
  body << html_table(estimates_table("Lai third-order model (Table 3 names)", id_result.lai3));
  const auto& f = id_result.fit;
  std::ostringstream fit;
  fit << "Lai fit: rms " << format_fixed(f.rms_um, 4) << " \u00b5m over " << f.n << " points, condition number "
      << format_number(f.condition_number, 3) << ".";
  body << "<p>" << html_escape(fit.str()) << "</p>";
  if (f.unidentifiable.empty()) return;
  std::string names;
  for (const auto& n : f.unidentifiable) names += (names.empty() ? "" : ", ") + n;
  body << html_note("Not separable by these patterns (refused, not reported): " + names);
  if (!f.combinations.empty()) {
    Table c{"Combinations these patterns do determine", {"combination", "value \u00b1 u"}};
    for (const auto& k : f.combinations)
      c.rows.push_back({html_escape(k.expression), html_escape(with_uncertainty(k.value, k.u))});
    body << html_table(c);
  }
}

}  // namespace

std::string dbb_section(const std::vector<std::string>& paths, const std::string& id) {
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
  body << ". Identified together (Lai, Liao and Chieng 1997 third-order model and the ballbar diagnostics; sign "
          "conventions in docs/conventions.md).</p>";

  models::dbb::Identification id_result;
  bool identified = false;
  std::string refusal;
  try {
    id_result = models::dbb::identify(runs);
    identified = true;
  } catch (const std::exception& e) {
    refusal = e.what();
  }
  // The polar plots, beside them the errors ranked by their part of the circular deviation.
  body << "<div class=\"side-by-side\">";
  setup_plots(body, runs, identified ? &id_result : nullptr);
  if (identified && !id_result.ranking.empty()) ranking_chart(body, id_result);
  body << "</div>";
  if (!identified) {
    body << html_note("Identification refused: " + refusal);
  } else {
    runs_and_diagnostics_tables(body, id_result);
    lai_tables(body, id_result);
  }
  return html_section(std::string(results::dbb_kind.name), id, "Double ball bar: circular tests", body.str());
}

}  // namespace guideway::report
