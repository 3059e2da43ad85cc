// Straightness traverses, Union Jack plates and run-out revolutions (models/flatness).
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>

#include "core/csv_table.hpp"
#include "models/flatness/error_motion.hpp"
#include "models/flatness/runout.hpp"
#include "models/flatness/straightness.hpp"
#include "models/flatness/union_jack.hpp"
#include "report/html.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"
#include "results/parameters.hpp"

namespace guideway::report {

namespace {

std::string um_u(double v_m, double u_m) { return html_escape(with_uncertainty(v_m * 1e6, u_m * 1e6)); }

std::string straightness_plane(const models::flatness::StraightnessProfile& p, const std::string& source) {
  std::ostringstream body;
  const double x0 = p.x_m.front();
  LinePlot plot;
  plot.title = "Straightness, " + p.plane + " plane (" + base_name(source) + ")";
  plot.x_label = "position x / mm";
  plot.y_label = "height / \u00b5m";
  Series h{"measured heights (integrated angles)", {}, {}, palette(0), Style::line_markers, 1.6};
  Series ep{"end-point line", {}, {}, palette(1), Style::dashed, 1.4};
  Series ls{"least-squares line", {}, {}, palette(2), Style::dashed, 1.4};
  for (std::size_t k = 0; k < p.x_m.size(); ++k) {
    const double x = p.x_m[k];
    h.x.push_back(x * 1e3);
    h.y.push_back(p.height_m[k] * 1e6);
  }
  for (double x : {p.x_m.front(), p.x_m.back()}) {
    ep.x.push_back(x * 1e3);
    ep.y.push_back((p.end_point.intercept_m + p.end_point.slope * (x - x0)) * 1e6);
    ls.x.push_back(x * 1e3);
    ls.y.push_back((p.least_squares.intercept_m + p.least_squares.slope * (x - x0)) * 1e6);
  }
  Series poly{"polynomial fit, order " + std::to_string(p.polynomial.order) + " (Mu Eq. 10)", {}, {}, palette(3),
              Style::line, 1.4};
  const int fine = 200;
  for (int i = 0; i <= fine; ++i) {
    const double x = x0 + (p.x_m.back() - x0) * i / fine;
    poly.x.push_back(x * 1e3);
    poly.y.push_back(p.polynomial(x - x0) * 1e6);
  }
  plot.series = {h, ep, ls, poly};
  body << html_figure(render(plot),
                      "Heights integrated from the autocollimator angles (h<sub>0</sub> = 0) with the ISO 230-1 "
                      "reference lines and the polynomial of Mu's Eq. 10 (order by BIC).");

  LinePlot dev;
  dev.title = "Deviations from the least-squares line, " + p.plane + " plane";
  dev.x_label = "position x / mm";
  dev.y_label = "deviation / \u00b5m";
  Series d{"deviation from the least-squares line", {}, {}, palette(2), Style::line_markers, 1.4};
  Series up{"+2u (random walk of the angle noise)", {}, {}, "#999999", Style::dashed, 1.0};
  Series lo{"\u22122u", {}, {}, "#999999", Style::dashed, 1.0};
  for (std::size_t k = 0; k < p.x_m.size(); ++k) {
    d.x.push_back(p.x_m[k] * 1e3);
    d.y.push_back(p.least_squares.deviation_m[k] * 1e6);
    const double u = k < p.least_squares.u_deviation_m.size() ? p.least_squares.u_deviation_m[k] : 0.0;
    up.x.push_back(p.x_m[k] * 1e3);
    up.y.push_back(2 * u * 1e6);
    lo.x.push_back(p.x_m[k] * 1e3);
    lo.y.push_back(-2 * u * 1e6);
  }
  dev.series = {d, up, lo};
  body << html_figure(render(dev), "Deviations from the least-squares line with their expanded uncertainty (k = 2).");

  Table t{"Straightness, " + html_escape(p.plane) + " plane (ISO 230-1)",
          {"reference", "straightness / \u00b5m (\u00b1 u)", "selection bias / \u00b5m"},
          {}};
  const auto row = [&](const char* name, const models::flatness::ReferenceLine& r) {
    t.rows.push_back({name, um_u(r.straightness_m, r.u_straightness_m), format_fixed(r.selection_bias_m * 1e6, 3)});
  };
  row("end-point line", p.end_point);
  row("least-squares line", p.least_squares);
  row("minimum zone", p.minimum_zone);
  body << html_table(t);
  Table c{"Polynomial (Mu Eq. 10), x from the first station in mm", {"coefficient", "value \u00b1 u", "unit"}, {}};
  for (std::size_t k = 1; k < p.polynomial.b.size(); ++k) {
    // b_k in m/m^k -> um/mm^k
    const double scale = 1e6 / std::pow(1e3, static_cast<double>(k));
    const double u = k < p.polynomial.u_b.size() ? p.polynomial.u_b[k] : NAN;
    c.rows.push_back({"b" + std::to_string(k), html_escape(with_uncertainty(p.polynomial.b[k] * scale, u * scale)),
                      k == 1 ? "\u00b5m/mm" : "\u00b5m/mm<sup>" + std::to_string(k) + "</sup>"});
  }
  c.rows.push_back({"residual rms / max", format_fixed(p.polynomial.residual_rms_m * 1e6, 4) + " / " +
                                              format_fixed(p.polynomial.residual_max_m * 1e6, 4),
                    "\u00b5m"});
  body << html_table(c);
  return body.str();
}

}  // namespace

std::string straightness_section(const std::string& path, const std::string& id) {
  models::flatness::StraightnessResult r;
  try {
    r = models::flatness::identify_straightness(models::flatness::read_angle_traverse(path));
  } catch (const CsvError& e) {
    throw ReportError(e.what());
  } catch (const std::invalid_argument& e) {
    throw ReportError(path + ": " + e.what());
  }
  std::ostringstream body;
  body << "<p><code>" << html_escape(base_name(path)) << "</code>: " << r.readings
       << " autocollimator readings, reflector foot spacing " << format_number(r.step_m * 1e3, 4) << " mm.</p>";
  body << straightness_plane(r.vertical, path);
  if (r.horizontal) body << straightness_plane(*r.horizontal, path);
  return html_section("straightness", id, "Straightness: " + base_name(path), body.str());
}

std::string union_jack_section(const std::string& path, const std::string& id) {
  models::flatness::UnionJackResult r;
  bool inch = false;
  try {
    const auto set = models::flatness::read_union_jack(path);
    inch = set.inch_units;
    r = models::flatness::evaluate_union_jack(set);
  } catch (const CsvError& e) {
    throw ReportError(e.what());
  } catch (const std::invalid_argument& e) {
    throw ReportError(path + ": " + e.what());
  }
  // Stations shared by several lines (corners, edge midpoints, the centre) appear once, averaged.
  HeightMap map;
  map.title = "Surface plate heights (Union Jack, Moody's evaluation)";
  map.x_label = "x (east) / mm";
  map.y_label = "y (north) / mm";
  map.z_label = "height above the lowest station / \u00b5m";
  std::map<std::pair<long long, long long>, std::size_t> index;
  std::vector<double> sum, count;
  for (const auto& line : r.lines) {
    std::vector<std::size_t> poly;
    for (const auto& s : line.stations) {
      const std::pair<long long, long long> key{std::llround(s.x_steps * 1e6), std::llround(s.y_steps * 1e6)};
      auto [it, inserted] = index.emplace(key, map.x.size());
      if (inserted) {
        map.x.push_back(s.x_steps * r.foot_spacing_m * 1e3);
        map.y.push_back(s.y_steps * r.foot_spacing_m * 1e3);
        sum.push_back(0);
        count.push_back(0);
      }
      sum[it->second] += s.height_m * 1e6;
      count[it->second] += 1;
      poly.push_back(it->second);
    }
    map.lines.push_back(poly);
    map.line_labels.push_back(line.name);
  }
  for (std::size_t k = 0; k < sum.size(); ++k) map.z.push_back(sum[k] / count[k]);

  std::ostringstream body;
  body << "<p><code>" << html_escape(path) << "</code>: foot spacing " << format_number(r.foot_spacing_m * 1e3, 4)
       << " mm, " << r.long_steps << " \u00d7 " << r.short_steps << " steps, diagonals " << r.diagonal_steps
       << " steps, " << map.x.size() << " stations.</p>";
  body << html_figure(render(map),
                      "Station heights (dots) on the eight measuring lines (white), colour interpolated between "
                      "the stations by inverse distance weighting; plate coordinates from the SW corner.");
  Table t{"Flatness", {"quantity", "value / \u00b5m", inch ? "value / (10 \u00b5in)" : ""}, {}};
  if (!inch) t.header.pop_back();
  const auto row = [&](const std::string& name, double m) {
    std::vector<std::string> cells{html_escape(name), format_fixed(m * 1e6, 3)};
    if (inch) cells.push_back(format_fixed(m / 254e-9, 3));
    t.rows.push_back(cells);
  };
  row("flatness (Moody datum)", r.flatness_m);
  row("flatness about the least-squares plane", r.flatness_lsq_plane_m);
  row("flatness, minimum zone", r.flatness_min_zone_m);
  for (const auto& line : r.lines)
    if (line.closure_m) row("closure error of " + line.name, *line.closure_m);
  body << html_table(t);
  for (const auto& w : r.warnings) body << html_note(w);
  return html_section("unionjack", id, "Surface plate flatness (Union Jack): " + base_name(path), body.str());
}

std::string runout_section(const std::string& path, const std::string& id) {
  models::flatness::RunoutRevolution rev;
  models::flatness::RunoutResult r;
  try {
    rev = models::flatness::read_runout_revolution(path);
    r = models::flatness::identify_runout(rev);
  } catch (const CsvError& e) {
    throw ReportError(e.what());
  } catch (const std::invalid_argument& e) {
    throw ReportError(path + ": " + e.what());
  }
  LinePlot plot;
  plot.title = "Axial run-out of the thrust plate (" + base_name(path) + ")";
  plot.x_label = "spindle angle / deg";
  plot.y_label = "run-out / \u00b5m";
  Series m{"measured", {}, {}, palette(0), Style::line_markers, 1.0};
  Series fit{"once per revolution: c + A cos(\u03c6 \u2212 \u03c6\u2080)", {}, {}, palette(1), Style::dashed, 1.8};
  for (std::size_t k = 0; k < rev.angle_rad.size(); ++k) {
    m.x.push_back(rev.angle_rad[k] * 180 / std::numbers::pi);
    m.y.push_back(rev.runout_m[k] * 1e6);
  }
  double amin = INFINITY, amax = -INFINITY;
  for (double a : rev.angle_rad) {
    amin = std::min(amin, a);
    amax = std::max(amax, a);
  }
  for (int i = 0; i <= 360; ++i) {
    const double a = amin + (amax - amin) * i / 360;
    fit.x.push_back(a * 180 / std::numbers::pi);
    fit.y.push_back((r.offset_m + r.amplitude_m * std::cos(a - r.phase_rad)) * 1e6);
  }
  if (rev.angle_rad.size() > 400) m.style = Style::line;
  plot.series = {m, fit};
  std::ostringstream body;
  body << "<p><code>" << html_escape(base_name(path)) << "</code>: " << r.samples
       << " samples; inductance micrometer at the rim of a " << format_number(r.plate_diameter_m * 1e3, 4)
       << " mm thrust plate (Mu 2012, Fig. 10).</p>";
  body << html_figure(render(plot), "The revolution and its least-squares once-per-revolution component; r = 2A is "
                                    "the tilt of the plate seen at its rim.");
  Table t{"Squareness from run-out (Mu Eq. 21)", {"quantity", "value \u00b1 u", "unit"}, {}};
  t.rows.push_back({"amplitude A", um_u(r.amplitude_m, r.u_amplitude_m), "\u00b5m"});
  t.rows.push_back({"phase of the maximum \u03c6\u2080",
                    html_escape(with_uncertainty(r.phase_rad * 180 / std::numbers::pi,
                                              r.u_phase_rad * 180 / std::numbers::pi)),
                    "deg"});
  t.rows.push_back({"run-out r = 2A", um_u(r.runout_m, r.u_runout_m), "\u00b5m"});
  t.rows.push_back({"parallelism p", format_fixed(r.parallelism_m * 1e6, 4), "\u00b5m"});
  t.rows.push_back({"twice per revolution", format_fixed(r.second_harmonic_m * 1e6, 4), "\u00b5m"});
  t.rows.push_back({"squareness \u03b8\u2080 = (r + p)/L",
                    html_escape(with_uncertainty(r.deflection_rad * 1e6, r.u_deflection_rad * 1e6)), "\u00b5rad"});
  if (r.squareness_amplitude_m && r.travel_m)
    t.rows.push_back({"over the travel of " + format_number(*r.travel_m * 1e3, 4) + " mm",
                      um_u(*r.squareness_amplitude_m, r.u_squareness_amplitude_m.value_or(0)), "\u00b5m"});
  t.rows.push_back({"fit residual rms", format_fixed(r.residual_rms_m * 1e6, 4), "\u00b5m"});
  body << html_table(t);
  if (models::flatness::whole_revolutions(rev.angle_rad) >= 1) {
    // ISO 230-7 values of the record (models/flatness/error_motion: the once-per-revolution term removed).
    const auto em = models::flatness::error_motion(rev.angle_rad, rev.runout_m, path);
    Table e{"Spindle error motion (ISO 230-7) over " + std::to_string(em.revolutions) + " revolution" +
                (em.revolutions == 1 ? "" : "s") + ", the once-per-revolution term removed",
            {"quantity", "value", "unit"},
            {}};
    for (const auto& [p, v] : {std::pair{&results::total_error_motion, em.total_m},
                               std::pair{&results::synchronous_error_motion, em.synchronous_m},
                               std::pair{&results::asynchronous_error_motion, em.asynchronous_m},
                               std::pair{&results::fundamental_error_motion, em.fundamental_m}}) {
      const auto shown = results::shown(results::name(*p), v * 1e6, std::numeric_limits<double>::quiet_NaN());
      e.rows.push_back({html_escape(shown.label), html_escape(shown.value), html_escape(shown.unit)});
    }
    body << html_table(e);
  }
  return html_section("runout", id, "Spindle run-out and squareness: " + base_name(path), body.str());
}

}  // namespace guideway::report
