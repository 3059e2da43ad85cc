// Explanations of a model/recording mismatch: rendered from the JSON of `guideway explain --json`
// (docs/reports.md lists the fields used and the optional residual curves).
#include <algorithm>
#include <cmath>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/csv_table.hpp"
#include "report/html.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"
#include "results/parameters.hpp"

namespace guideway::report {

namespace {

using nlohmann::json;

double num(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return NAN;
  return j[key].get<double>();
}

std::string text(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key)) return {};
  if (j[key].is_string()) return j[key].get<std::string>();
  if (j[key].is_null()) return {};
  return j[key].dump();
}

std::string cell(double v, int sig = 4) { return std::isfinite(v) ? format_number(v, sig) : "&ndash;"; }

// A p-value of 0 is one below the smallest double the test could print.
std::string p_cell(double p) { return p == 0 ? "&lt;1e-300" : cell(p, 3); }

// "angle_deg" -> "angle / deg": the unit suffix of a domain name as an axis label.
std::string axis_label(const std::string& name) {
  const auto [q, unit] = results::split_unit(name);
  return unit.empty() ? name : q + " / " + unit;
}

json read_explanation(const std::string& path) {
  try {
    return json::parse(read_text_file(path));
  } catch (const json::parse_error& e) {
    throw ReportError(path + ": not valid JSON (" + e.what() + ")");
  } catch (const CsvError& e) {
    throw ReportError(e.what());
  }
}

// The file, its model, how many findings and whether the residual is explained; samples, noise and the
// held-out scheme.
void summary_paragraph(std::ostringstream& body, const std::string& path, const json& j) {
  const json& findings = j["findings"];
  const bool unexplained = j.value("unexplained", false);
  body << "<p><code>" << html_escape(base_name(path)) << "</code>: model <b>" << html_escape(text(j, "model"))
       << "</b>, " << findings.size() << " finding(s)";
  if (findings.empty()) body << " (nothing significant beyond the base model)";
  body << "; residual " << (unexplained ? "<b>not explained</b> by the effects Guideway knows" : "explained") << ".";
  if (j.contains("n") && j["n"].is_number()) body << " " << j["n"].get<double>() << " samples.";
  if (std::isfinite(num(j, "noise_um"))) body << " Noise " << format_number(num(j, "noise_um"), 3) << " \u00b5m.";
  if (!text(j, "heldout_scheme").empty()) body << " Held out: " << html_escape(text(j, "heldout_scheme")) << ".";
  body << "</p>";
}

// RMS after each step, in sample and held out.
void rms_chart(std::ostringstream& body, const json& base, const json& findings) {
  BarChart chart;
  chart.title = "Residual RMS after each finding";
  chart.x_label = "base model, then + each finding (forward selection)";
  chart.y_label = "residual rms / \u00b5m";
  BarSeries in{"fitted data", {}, palette(0)};
  BarSeries out{"held-out data", {}, palette(1)};
  chart.categories.push_back("base model");
  in.values.push_back(num(base, "rms_um"));
  out.values.push_back(num(base, "heldout_rms_um"));
  for (const auto& f : findings) {
    chart.categories.push_back("+ " + results::in_words(text(f, "effect")));
    in.values.push_back(num(f, "rms_um_after"));
    out.values.push_back(num(f, "heldout_rms_um_after"));
  }
  chart.series = {in, out};
  body << html_figure(render(chart),
                      "Residual RMS of the base model and after adding each finding in turn (greedy "
                      "forward selection); held-out: data the fit did not see.");
}

// The findings by their part of the yardstick (a DBB run's circular deviation G), largest first.
void contribution_chart(std::ostringstream& body, const json& j, const json& findings) {
  std::vector<std::pair<double, std::string>> parts;
  for (const auto& f : findings)
    if (std::isfinite(num(f, "contribution_um")))
      parts.emplace_back(num(f, "contribution_um"), results::in_words(text(f, "effect")));
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
  if (j.contains("deviation") && j["deviation"].is_object())
    cap += " about the least-squares circle, against " + text(j["deviation"], "name") + " " +
           format_number(num(j["deviation"], "value_um"), 3) + " \u00b5m";
  cap += " (what to fix first).";
  body << html_figure(render(rank), html_escape(cap));
}

// The residual curves an explanation carries: one x grid, the runs, and per step one curve per run.
struct ResidualStep {
  std::string label;
  std::vector<std::vector<double>> y;
};
struct ResidualCurves {
  std::vector<double> x;
  std::vector<std::string> runs;
  std::vector<ResidualStep> steps;
  double lo = INFINITY, hi = -INFINITY;  // over every finite value
};

std::vector<double> numbers(const std::string& path, const json& a, const std::string& what) {
  if (!a.is_array()) throw ReportError(path + ": residuals: " + what + " is not an array");
  std::vector<double> v;
  for (const auto& e : a) v.push_back(e.is_number() ? e.get<double>() : NAN);
  return v;
}

ResidualCurves read_residual_curves(const std::string& path, const json& r) {
  ResidualCurves c;
  c.x = numbers(path, r.value("x", json()), "x");
  for (const auto& n : r.value("runs", json::array()))
    c.runs.push_back(n.is_string() ? n.get<std::string>() : n.dump());
  if (c.runs.empty()) throw ReportError(path + ": residuals: no \"runs\"");
  for (const auto& st : r["steps"]) {
    ResidualStep step{text(st, "label"), {}};
    const json curves_of_runs = st.is_object() ? st.value("residual_um", json()) : json();
    if (!curves_of_runs.is_array() || curves_of_runs.size() != c.runs.size())
      throw ReportError(path + ": residuals: step '" + step.label + "' needs one curve per run (" +
                        std::to_string(c.runs.size()) + ")");
    for (const auto& curve : curves_of_runs) {
      step.y.push_back(numbers(path, curve, "a curve of step '" + step.label + "'"));
      if (step.y.back().size() != c.x.size())
        throw ReportError(path + ": residuals: step '" + step.label + "' has a curve of " +
                          std::to_string(step.y.back().size()) + " values for " + std::to_string(c.x.size()) +
                          " x values");
      for (double v : step.y.back())
        if (std::isfinite(v)) {
          c.lo = std::min(c.lo, v);
          c.hi = std::max(c.hi, v);
        }
    }
    c.steps.push_back(std::move(step));
  }
  return c;
}

// Step k's panel: its residual per run on the common y scale, titled with its RMS in sample and held out.
void residual_panel(std::ostringstream& body, const ResidualCurves& c, std::size_t k, const json& fit,
                    const std::string& x_label, const Ticks& yt) {
  const double rms = num(fit, k == 0 ? "rms_um" : "rms_um_after");
  const double heldout = num(fit, k == 0 ? "heldout_rms_um" : "heldout_rms_um_after");
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
    plot.series.push_back({c.runs[run], c.x, c.steps[k].y[run], palette(run), Style::line, 1.1});
  body << html_figure(render(plot), k == 0 ? std::string("Before: the base model's residual, per run.")
                                           : "After adding " + html_escape(effect) +
                                                 (k > 1 ? " to the base and the findings before it" : " to the base") +
                                                 ", fitted jointly; per run.");
}

// Residual curves, when the explanation carries them: one panel per step (the base model, then after each
// finding in turn), the runs overlaid, every panel on the same y scale so the steps compare.
void residual_panels(std::ostringstream& body, const std::string& path, const json& j) {
  const json* curves = j.contains("residuals") && j["residuals"].is_object() && j["residuals"].contains("steps")
                           ? &j["residuals"]
                           : nullptr;
  if (!curves || !(*curves)["steps"].is_array() || (*curves)["steps"].empty()) {
    body << html_note(
        "This explanation carries no residual curves per step (optional \"residuals\" field with "
        "\"steps\", docs/explain.md); only the RMS values are shown.");
    return;
  }
  const ResidualCurves c = read_residual_curves(path, *curves);
  const Ticks yt = nice_ticks(std::isfinite(c.lo) ? c.lo : 0.0, std::isfinite(c.hi) ? c.hi : 1.0);
  const std::string x_label = axis_label(curves->value("domain", std::string("sample")));
  body << "<p>The residual (recording minus model) against " << html_escape(x_label)
       << " before and after each finding: the base model, then the base refitted jointly with the findings taken so "
          "far, one panel per step on one scale.</p><div class=\"residual-steps\">";
  const json& findings = j["findings"];
  for (std::size_t k = 0; k < c.steps.size(); ++k)
    residual_panel(body, c, k, k == 0 ? j["baseline"] : (k - 1 < findings.size() ? findings[k - 1] : json()), x_label,
                   yt);
  body << "</div>";
}

void findings_table(std::ostringstream& body, const json& findings) {
  Table ft{"Findings (in the order selected)",
           {"effect", "parameters (value \u00b1 u)", "\u0394BIC", "p", "rms after / \u00b5m",
            "held-out rms after / \u00b5m", "why"},
           {},
           "text"};
  for (const auto& f : findings) {
    std::string params;
    if (f.contains("parameters") && f["parameters"].is_object())
      for (const auto& [name, v] : f["parameters"].items()) {
        const double value = num(v, "value"), u = num(v, "u");
        const results::Shown shown = results::shown(name, value, u);
        params += (params.empty() ? "" : "<br>") + html_escape(shown.label) + " " + html_escape(shown.value) +
                  (shown.unit.empty() ? "" : " " + html_escape(shown.unit));
      }
    ft.rows.push_back({html_escape(results::in_words(text(f, "effect"))), params, cell(num(f, "delta_bic")),
                       p_cell(num(f, "p_value")), cell(num(f, "rms_um_after")), cell(num(f, "heldout_rms_um_after")),
                       "<span class=\"why\">" + html_escape(text(f, "why")) + "</span>"});
  }
  if (!findings.empty()) body << html_table(ft);
}

void fit_summary(std::ostringstream& body, const json& j) {
  const json& base = j["baseline"];
  Table st{"Fit summary", {"", "rms / \u00b5m", "held-out rms / \u00b5m", "BIC"}, {}};
  st.rows.push_back(
      {"base model", cell(num(base, "rms_um")), cell(num(base, "heldout_rms_um")), cell(num(base, "bic"), 6)});
  if (j.contains("final"))
    st.rows.push_back({"final", cell(num(j["final"], "rms_um")), cell(num(j["final"], "heldout_rms_um")),
                       cell(num(j["final"], "bic"), 6)});
  body << html_table(st);
}

// Where the residual was and is structured, the effects considered and the notes.
void places_and_verdicts(std::ostringstream& body, const json& j) {
  const auto places = [&](const char* key, const char* caption) {
    if (!j.contains(key) || !j[key].is_array() || j[key].empty()) return;
    Table mt{caption, {"domain", "where", "band", "evidence"}, {}, "text"};
    for (const auto& m : j[key])
      mt.rows.push_back({html_escape(text(m, "domain")), html_escape(text(m, "where")), html_escape(text(m, "band")),
                         html_escape(text(m, "evidence"))});
    body << html_table(mt);
  };
  places("mismatch", "Where the base model's residual is structured");
  places("remaining", "Still structured after the findings");
  if (j.contains("considered") && j["considered"].is_array() && !j["considered"].empty()) {
    Table ct{"Effects considered", {"effect", "\u0394BIC", "p", "verdict"}, {}, "text"};
    for (const auto& c : j["considered"])
      ct.rows.push_back({html_escape(results::in_words(text(c, "effect"))), cell(num(c, "delta_bic")),
                         p_cell(num(c, "p_value")), html_escape(text(c, "verdict"))});
    body << html_table(ct);
  }
  if (j.contains("notes") && j["notes"].is_array())
    for (const auto& n : j["notes"])
      if (n.is_string()) body << html_note(n.get<std::string>());
}

}  // namespace

std::string explain_section(const std::string& path, const std::string& id) {
  const json j = read_explanation(path);
  const std::string title = "Explanation of the mismatch: " + base_name(path);
  // A session whose data no explanation model can use (the daemon's EXPLAIN says why, docs/protocol.md).
  if (j.is_object() && j.contains("not_analysed") && j["not_analysed"].is_string())
    return html_section("explain", id, title,
                        "<p><code>" + html_escape(base_name(path)) + "</code>: model <b>" +
                            html_escape(text(j, "model")) + "</b>: not analysed.</p>" +
                            html_note("Not analysed: " + j["not_analysed"].get<std::string>()));
  if (!j.is_object() || !j.contains("baseline") || !j.contains("findings") || !j["findings"].is_array())
    throw ReportError(path +
                      ": not an explanation (needs \"baseline\" and a \"findings\" array, as written by "
                      "guideway explain --json)");
  std::ostringstream body;
  summary_paragraph(body, path, j);
  rms_chart(body, j["baseline"], j["findings"]);
  contribution_chart(body, j, j["findings"]);
  residual_panels(body, path, j);
  findings_table(body, j["findings"]);
  fit_summary(body, j);
  places_and_verdicts(body, j);
  return html_section("explain", id, title, body.str());
}

}  // namespace guideway::report
