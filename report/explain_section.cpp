// Explanations of a model/recording mismatch: rendered from the explanation `guideway explain --json` writes
// (results/explanation.hpp; docs/reports.md lists the fields used and the optional residual curves).
#include <algorithm>
#include <cmath>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/csv_table.hpp"
#include "report/html.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"
#include "results/explanation.hpp"
#include "results/parameters.hpp"

namespace guideway::report {

namespace {

using results::ExplainFinding;
using results::Explanation;

std::string cell(double v, int sig = 4) { return std::isfinite(v) ? format_number(v, sig) : "&ndash;"; }

// A p-value of 0 is one below the smallest double the test could print.
std::string p_cell(double p) { return p == 0 ? "&lt;1e-300" : cell(p, 3); }

// "angle_deg" -> "angle / deg": the unit suffix of a domain name as an axis label.
std::string axis_label(const std::string& name) {
  const auto [q, unit] = results::split_unit(name);
  return unit.empty() ? name : q + " / " + unit;
}

nlohmann::json read_explanation_json(const std::string& path) {
  try {
    return nlohmann::json::parse(read_text_file(path));
  } catch (const nlohmann::json::parse_error& e) {
    throw ReportError(path + ": not valid JSON (" + e.what() + ")");
  } catch (const CsvError& e) {
    throw ReportError(e.what());
  }
}

// The file, its model, how many findings and whether the residual is explained; samples, noise and the
// held-out scheme.
void summary_paragraph(std::ostringstream& body, const std::string& path, const Explanation& e) {
  body << "<p><code>" << html_escape(base_name(path)) << "</code>: model <b>" << html_escape(e.model) << "</b>, "
       << e.findings.size() << " finding(s)";
  if (e.findings.empty()) body << " (nothing significant beyond the base model)";
  body << "; residual " << (e.unexplained ? "<b>not explained</b> by the effects Guideway knows" : "explained") << ".";
  if (e.n > 0) body << " " << static_cast<double>(e.n) << " samples.";
  if (std::isfinite(e.noise_um)) body << " Noise " << format_number(e.noise_um, 3) << " \u00b5m.";
  if (!e.heldout_scheme.empty()) body << " Held out: " << html_escape(e.heldout_scheme) << ".";
  body << "</p>";
}

// RMS after each step, in sample and held out.
void rms_chart(std::ostringstream& body, const Explanation& e) {
  BarChart chart;
  chart.title = "Residual RMS after each finding";
  chart.x_label = "base model, then + each finding (forward selection)";
  chart.y_label = "residual rms / \u00b5m";
  BarSeries in{"fitted data", {}, palette(0)};
  BarSeries out{"held-out data", {}, palette(1)};
  chart.categories.push_back("base model");
  in.values.push_back(e.baseline.rms_um);
  out.values.push_back(e.baseline.heldout_rms_um);
  for (const ExplainFinding& f : e.findings) {
    chart.categories.push_back("+ " + results::in_words(f.effect));
    in.values.push_back(f.rms_um_after);
    out.values.push_back(f.heldout_rms_um_after);
  }
  chart.series = {in, out};
  body << html_figure(render(chart),
                      "Residual RMS of the base model and after adding each finding in turn (greedy "
                      "forward selection); held-out: data the fit did not see.");
}

// The findings by their part of the yardstick (a DBB run's circular deviation G), largest first.
void contribution_chart(std::ostringstream& body, const Explanation& e) {
  std::vector<std::pair<double, std::string>> parts;
  for (const ExplainFinding& f : e.findings)
    if (std::isfinite(f.contribution_um)) parts.emplace_back(f.contribution_um, results::in_words(f.effect));
  std::stable_sort(parts.begin(), parts.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  if (parts.empty()) return;
  BarChart rank;
  rank.title = "Findings, largest first";
  rank.x_label = "finding";
  rank.y_label = "size of its term / \u00b5m";
  rank.horizontal = true;
  BarSeries sizes{"range of the fitted term", {}, palette(2)};
  for (const auto& [v, name] : parts) {
    rank.categories.push_back(name);
    sizes.values.push_back(v);
  }
  rank.series = {sizes};
  std::string cap = "Each finding's fitted term: its range";
  if (e.deviation)
    cap += " about the least-squares circle, against " + e.deviation->name + " " +
           format_number(e.deviation->value_um, 3) + " \u00b5m";
  cap += " (what to fix first).";
  body << html_figure(render(rank), html_escape(cap));
}

// The residual curves' range over every finite value, after checking that every step has one curve per run
// and every curve a value per x.
std::pair<double, double> curves_range(const std::string& path, const results::ExplainResiduals& c) {
  if (c.runs.empty()) throw ReportError(path + ": residuals: no \"runs\"");
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& step : c.steps) {
    if (step.residual_um.size() != c.runs.size())
      throw ReportError(path + ": residuals: step '" + step.label + "' needs one curve per run (" +
                        std::to_string(c.runs.size()) + ")");
    for (const auto& curve : step.residual_um) {
      if (curve.size() != c.x.size())
        throw ReportError(path + ": residuals: step '" + step.label + "' has a curve of " +
                          std::to_string(curve.size()) + " values for " + std::to_string(c.x.size()) + " x values");
      for (double v : curve)
        if (std::isfinite(v)) {
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
    }
  }
  return {lo, hi};
}

// Step k's panel: its residual per run on the common y scale, titled with its RMS in sample and held out.
void residual_panel(std::ostringstream& body, const results::ExplainResiduals& c, std::size_t k, double rms,
                    double heldout, const std::string& x_label, const Ticks& yt) {
  const auto value = [](double v) { return std::isfinite(v) ? format_number(v, 3) : std::string("\u2013"); };
  std::string effect = c.steps[k].label;
  if (effect.rfind("+ ", 0) == 0) effect = effect.substr(2);
  effect = results::in_words(effect);
  LinePlot plot;
  plot.title =
      (k == 0 ? "Residual of the base model" : "Residual after + " + effect + " (finding " + std::to_string(k) + ")") +
      ": rms " + value(rms) + " \u00b5m, held out " + value(heldout) + " \u00b5m";
  plot.x_label = x_label;
  plot.y_label = "residual / \u00b5m";
  plot.y_range = Range{yt.values.front(), yt.values.back()};
  plot.height = 220;
  for (std::size_t run = 0; run < c.runs.size(); ++run)
    plot.series.push_back({c.runs[run], c.x, c.steps[k].residual_um[run], palette(run), Style::line, 1.1});
  body << html_figure(render(plot), k == 0 ? std::string("Before: the base model's residual, per run.")
                                           : "After adding " + html_escape(effect) +
                                                 (k > 1 ? " to the base and the findings before it" : " to the base") +
                                                 ", fitted jointly; per run.");
}

// Residual curves, when the explanation carries them: one panel per step (the base model, then after each
// finding in turn), the runs overlaid, every panel on the same y scale so the steps compare.
void residual_panels(std::ostringstream& body, const std::string& path, const Explanation& e) {
  if (!e.residuals || e.residuals->steps.empty()) {
    body << html_note(
        "This explanation carries no residual curves per step (optional \"residuals\" field with "
        "\"steps\", docs/explain.md); only the RMS values are shown.");
    return;
  }
  const results::ExplainResiduals& c = *e.residuals;
  const auto [lo, hi] = curves_range(path, c);
  const Ticks yt = nice_ticks(std::isfinite(lo) ? lo : 0.0, std::isfinite(hi) ? hi : 1.0);
  const std::string x_label = axis_label(c.domain.empty() ? std::string("sample") : c.domain);
  body << "<p>The residual (recording minus model) against " << html_escape(x_label)
       << " before and after each finding: the base model, then the base refitted jointly with the findings taken so "
          "far, one panel per step on one scale.</p><div class=\"residual-steps\">";
  for (std::size_t k = 0; k < c.steps.size(); ++k) {
    const ExplainFinding* f = k > 0 && k - 1 < e.findings.size() ? &e.findings[k - 1] : nullptr;
    const double rms = k == 0 ? e.baseline.rms_um : f ? f->rms_um_after : NAN;
    const double heldout = k == 0 ? e.baseline.heldout_rms_um : f ? f->heldout_rms_um_after : NAN;
    residual_panel(body, c, k, rms, heldout, x_label, yt);
  }
  body << "</div>";
}

void findings_table(std::ostringstream& body, const std::vector<ExplainFinding>& findings) {
  Table ft{"Findings (in the order selected)",
           {"effect", "parameters (value \u00b1 u)", "\u0394BIC", "p", "rms after / \u00b5m",
            "held-out rms after / \u00b5m", "why"},
           {},
           "text"};
  for (const ExplainFinding& f : findings) {
    std::string params;
    for (const auto& [name, v] : f.parameters) {
      const results::Shown shown = results::shown(name, v.value, v.u);
      params += (params.empty() ? "" : "<br>") + html_escape(shown.label) + " " + html_escape(shown.value) +
                (shown.unit.empty() ? "" : " " + html_escape(shown.unit));
    }
    ft.rows.push_back({html_escape(results::in_words(f.effect)), params, cell(f.delta_bic), p_cell(f.p_value),
                       cell(f.rms_um_after), cell(f.heldout_rms_um_after),
                       "<span class=\"why\">" + html_escape(f.why) + "</span>"});
  }
  if (!findings.empty()) body << html_table(ft);
}

void fit_summary(std::ostringstream& body, const Explanation& e) {
  Table st{"Fit summary", {"", "rms / \u00b5m", "held-out rms / \u00b5m", "BIC"}, {}};
  const auto row = [&](const char* name, const results::ExplainFit& f) {
    st.rows.push_back({name, cell(f.rms_um), cell(f.heldout_rms_um), cell(f.bic, 6)});
  };
  row("base model", e.baseline);
  row("final", e.final_fit);
  body << html_table(st);
}

// Where the residual was and is structured, the effects considered and the notes.
void places_and_verdicts(std::ostringstream& body, const Explanation& e) {
  const auto places = [&](const std::vector<results::ExplainPlace>& v, const char* caption) {
    if (v.empty()) return;
    Table mt{caption, {"domain", "where", "band", "evidence"}, {}, "text"};
    for (const auto& m : v)
      mt.rows.push_back({html_escape(m.domain), html_escape(m.where), html_escape(m.band), html_escape(m.evidence)});
    body << html_table(mt);
  };
  places(e.mismatch, "Where the base model's residual is structured");
  places(e.remaining, "Still structured after the findings");
  if (!e.considered.empty()) {
    Table ct{"Effects considered", {"effect", "\u0394BIC", "p", "verdict"}, {}, "text"};
    for (const auto& c : e.considered)
      ct.rows.push_back(
          {html_escape(results::in_words(c.effect)), cell(c.delta_bic), p_cell(c.p_value), html_escape(c.verdict)});
    body << html_table(ct);
  }
  for (const auto& n : e.notes) body << html_note(n);
}

}  // namespace

std::string explain_section(const std::string& path, const std::string& id) {
  const nlohmann::json j = read_explanation_json(path);
  const std::string title = "Explanation of the mismatch: " + base_name(path);
  if (!results::is_explanation(j))
    throw ReportError(path +
                      ": not an explanation (needs \"baseline\" and a \"findings\" array, as written by "
                      "guideway explain --json)");
  Explanation e;
  try {
    e = results::explanation_from_json(j);
  } catch (const results::ExplanationFormatError& error) {
    throw ReportError(path + ": not an explanation: " + error.what());
  }
  // A session whose data no explanation model can use (the daemon's EXPLAIN says why, docs/protocol.md).
  if (!e.not_analysed.empty())
    return html_section("explain", id, title,
                        "<p><code>" + html_escape(base_name(path)) + "</code>: model <b>" + html_escape(e.model) +
                            "</b>: not analysed.</p>" + html_note("Not analysed: " + e.not_analysed));
  std::ostringstream body;
  summary_paragraph(body, path, e);
  rms_chart(body, e);
  contribution_chart(body, e);
  residual_panels(body, path, e);
  findings_table(body, e.findings);
  fit_summary(body, e);
  places_and_verdicts(body, e);
  return html_section("explain", id, title, body.str());
}

}  // namespace guideway::report
