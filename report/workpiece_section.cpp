// Mu 2012 Figures 8-9 as bars: the correlation of each profile (before the wavelet step) and of its
// low-frequency part s1 (after) with the simulated squareness y1 and straightness y2
// (models/flatness/workpiece_flatness), when the report has profiles and the carriage's traverse.
#include <optional>
#include <sstream>
#include <tuple>

#include "models/flatness/runout.hpp"

#include "models/flatness/straightness.hpp"
#include "core/csv_table.hpp"
#include "models/flatness/workpiece_flatness.hpp"
#include "report/html.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"

namespace guideway::report {

std::string workpiece_correlation_html(const std::vector<std::string>& profiles, const std::string& traverse,
                                       const std::string& runout, const ReportOptions& options) {
  models::flatness::WorkpieceFlatnessResult r;
  try {
    std::vector<models::flatness::WorkpieceProfile> ps;
    for (const auto& p : profiles) ps.push_back(models::flatness::read_workpiece_profile(p));
    std::optional<models::flatness::RunoutRevolution> rev;
    if (!runout.empty()) rev = models::flatness::read_runout_revolution(runout);
    models::flatness::WorkpieceFlatnessOptions opt;
    opt.wavelet = options.wavelet;
    opt.levels = options.wavelet_level;
    r = models::flatness::analyse_workpiece_flatness(ps, models::flatness::read_angle_traverse(traverse), rev, opt);
  } catch (const std::exception& e) {
    return html_note(std::string("Correlation with the carriage errors not computed: ") + e.what());
  }
  std::ostringstream body;
  body << "<h3>Which carriage error shows on the part (Mu 2012, Eqs. 19-20, Figures 8-9)</h3>";
  BarChart chart;
  chart.title = "Correlation with the simulated carriage errors";
  chart.x_label = "profile (feed rate)";
  chart.y_label = "correlation coefficient \u03b3 / 1";
  chart.y_range = Range{-1.0, 1.0};
  BarSeries sq_b{"squareness y1, before (x)", {}, "#9ecae1"}, sq_a{"squareness y1, after (s1)", {}, palette(0)};
  BarSeries st_b{"straightness y2, before (x)", {}, "#fdae6b"}, st_a{"straightness y2, after (s1)", {}, palette(1)};
  for (const auto& p : r.profiles) {
    chart.categories.push_back(base_name(p.source) + " (" + format_number(p.feed_m_per_s * 60000, 3) + " mm/min)");
    for (const auto& c : p.correlations) {
      auto [before, after] = c.name == "squareness" ? std::tie(sq_b, sq_a) : std::tie(st_b, st_a);
      before.values.push_back(c.gamma_before);
      after.values.push_back(c.gamma_after);
    }
  }
  chart.series = {sq_b, sq_a, st_b, st_a};
  std::ostringstream cap;
  cap << "Pearson coefficients of each profile with the squareness (y1, a line) and with the straightness from "
      << html_escape(base_name(traverse)) << " (y2, Eq. 10), before (Eq. 19) and after (Eq. 20) the wavelet step ("
      << html_escape(r.wavelet) << ", " << r.levels << " levels). Dominant: <b>" << html_escape(r.dominant)
      << "</b>, impact factor " << format_number(r.impact_factor, 3) << ".";
  body << html_figure(render(chart), cap.str());
  Table t{"Squareness identified from the profiles", {"quantity", "value \u00b1 u", "unit"}};
  t.rows.push_back({"squareness", html_escape(with_uncertainty(r.squareness_rad * 1e6, r.u_squareness_rad * 1e6)),
                    "\u00b5rad"});
  t.rows.push_back({"over " + format_number(r.travel_m * 1e3, 4) + " mm",
                    html_escape(with_uncertainty(r.squareness_amplitude_m * 1e6, r.u_squareness_amplitude_m * 1e6)),
                    "\u00b5m"});
  if (r.runout_check) {
    const auto& c = *r.runout_check;
    t.rows.push_back({"run-out (Eq. 21) \u03b8\u2080",
                      html_escape(with_uncertainty(c.runout.deflection_rad * 1e6, c.runout.u_deflection_rad * 1e6)),
                      "\u00b5rad"});
    t.rows.push_back({"|q| \u2212 \u03b8\u2080", html_escape(with_uncertainty(c.difference_rad * 1e6, c.u_difference_rad * 1e6)) +
                                                  (c.consistent ? " (consistent)" : " (<b>inconsistent</b>)"),
                      "\u00b5rad"});
  }
  body << html_table(t);
  return body.str();
}

}  // namespace guideway::report
