// Explanations of a model/recording mismatch: rendered from the JSON of `guideway explain --json`
// (issue 7's shape; docs/reports.md lists the fields used and the optional residual curves).
#include <algorithm>
#include <cmath>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/csv_table.hpp"
#include "report/html.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"

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
  const auto [q, unit] = split_unit(name);
  return unit.empty() ? name : q + " / " + unit;
}

}  // namespace

std::string explain_section(const std::string& path, const std::string& id) {
  json j;
  try {
    j = json::parse(read_text_file(path));
  } catch (const json::parse_error& e) {
    throw ReportError(path + ": not valid JSON (" + e.what() + ")");
  } catch (const CsvError& e) {
    throw ReportError(e.what());
  }
  if (!j.is_object() || !j.contains("baseline") || !j.contains("findings") || !j["findings"].is_array())
    throw ReportError(path + ": not an explanation (needs \"baseline\" and a \"findings\" array, as written by "
                             "guideway explain --json)");
  const json& base = j["baseline"];
  const json& findings = j["findings"];
  const bool unexplained = j.value("unexplained", false);

  std::ostringstream body;
  body << "<p><code>" << html_escape(base_name(path)) << "</code>: model <b>" << html_escape(text(j, "model"))
       << "</b>, " << findings.size() << " finding(s)";
  if (findings.empty()) body << " (nothing significant beyond the base model)";
  body << "; residual " << (unexplained ? "<b>not explained</b> by the effects Guideway knows" : "explained")
       << ".";
  if (j.contains("n") && j["n"].is_number()) body << " " << j["n"].get<double>() << " samples.";
  if (std::isfinite(num(j, "noise_um"))) body << " Noise " << format_number(num(j, "noise_um"), 3) << " \u00b5m.";
  if (!text(j, "heldout_scheme").empty()) body << " Held out: " << html_escape(text(j, "heldout_scheme")) << ".";
  body << "</p>";

  // RMS after each step, in sample and held out.
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
    chart.categories.push_back("+ " + text(f, "effect"));
    in.values.push_back(num(f, "rms_um_after"));
    out.values.push_back(num(f, "heldout_rms_um_after"));
  }
  chart.series = {in, out};
  body << html_figure(render(chart), "Residual RMS of the base model and after adding each finding in turn (greedy "
                                     "forward selection); held-out: data the fit did not see.");

  // Residual curves, when the explanation carries them.
  if (j.contains("residuals") && j["residuals"].is_object()) {
    const json& r = j["residuals"];
    LinePlot plot;
    plot.title = "Residual before and after the findings";
    plot.x_label = axis_label(r.value("domain", std::string("sample")));
    plot.y_label = "residual / \u00b5m";
    std::vector<double> x;
    if (r.contains("x") && r["x"].is_array())
      for (const auto& v : r["x"]) x.push_back(v.is_number() ? v.get<double>() : NAN);
    // "<run> baseline" / "<run> final" (guideway explain): one colour per run, light before, strong after.
    static const char* light[] = {"#9ecae1", "#fdae6b", "#a1d99b", "#fbb4d9"};
    std::vector<std::string> runs;
    const auto colour = [&](const std::string& label, std::size_t i) -> std::pair<std::string, double> {
      for (const char* suffix : {" baseline", " final"}) {
        const std::string sfx(suffix);
        if (label.size() > sfx.size() && label.compare(label.size() - sfx.size(), sfx.size(), sfx) == 0) {
          const auto run = label.substr(0, label.size() - sfx.size());
          auto it = std::find(runs.begin(), runs.end(), run);
          if (it == runs.end()) it = runs.insert(runs.end(), run);
          const auto k = static_cast<std::size_t>(it - runs.begin());
          return sfx == " baseline" ? std::make_pair(std::string(light[k % 4]), 1.0) : std::make_pair(palette(k), 1.4);
        }
      }
      return {palette(i), 1.2};
    };
    std::size_t i = 0;
    if (r.contains("series") && r["series"].is_array())
      for (const auto& s : r["series"]) {
        const std::string label = s.value("label", std::string("series"));
        const auto [color, width] = colour(label, i);
        Series line{label, x, {}, color, Style::line, width};
        if (s.contains("residual_um") && s["residual_um"].is_array())
          for (const auto& v : s["residual_um"]) line.y.push_back(v.is_number() ? v.get<double>() : NAN);
        if (line.y.size() != x.size())
          throw ReportError(path + ": residuals: series '" + line.label + "' has " + std::to_string(line.y.size()) +
                            " values for " + std::to_string(x.size()) + " x values");
        plot.series.push_back(std::move(line));
        ++i;
      }
    if (!plot.series.empty())
      body << html_figure(render(plot), "Residual (recording minus model) against " + html_escape(plot.x_label) +
                                            ": light, the base model; strong, after the findings.");
  } else {
    body << html_note("This explanation carries no residual curves (optional \"residuals\" field, docs/reports.md); "
                      "only the RMS values are shown.");
  }

  Table ft{"Findings (in the order selected)",
           {"effect", "parameters (value \u00b1 u)", "\u0394BIC", "p", "rms after / \u00b5m", "held-out rms after / \u00b5m",
            "why"},
           {},
           "text"};
  for (const auto& f : findings) {
    std::string params;
    if (f.contains("parameters") && f["parameters"].is_object())
      for (const auto& [name, v] : f["parameters"].items()) {
        const double value = num(v, "value"), u = num(v, "u");
        params += (params.empty() ? "" : "<br>") + html_escape(name) + " = " + html_escape(format_with_u(value, u));
      }
    ft.rows.push_back({html_escape(text(f, "effect")), params, cell(num(f, "delta_bic")), p_cell(num(f, "p_value")),
                       cell(num(f, "rms_um_after")), cell(num(f, "heldout_rms_um_after")),
                       "<span class=\"why\">" + html_escape(text(f, "why")) + "</span>"});
  }
  if (!findings.empty()) body << html_table(ft);

  Table st{"Fit summary", {"", "rms / \u00b5m", "held-out rms / \u00b5m", "BIC"}, {}};
  st.rows.push_back({"base model", cell(num(base, "rms_um")), cell(num(base, "heldout_rms_um")), cell(num(base, "bic"), 6)});
  if (j.contains("final"))
    st.rows.push_back({"final", cell(num(j["final"], "rms_um")), cell(num(j["final"], "heldout_rms_um")),
                       cell(num(j["final"], "bic"), 6)});
  body << html_table(st);

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
      ct.rows.push_back({html_escape(text(c, "effect")), cell(num(c, "delta_bic")), p_cell(num(c, "p_value")),
                         html_escape(text(c, "verdict"))});
    body << html_table(ct);
  }
  if (j.contains("notes") && j["notes"].is_array())
    for (const auto& n : j["notes"])
      if (n.is_string()) body << html_note(n.get<std::string>());
  return html_section("explain", id, "Explanation of the mismatch: " + base_name(path), body.str());
}

}  // namespace guideway::report
