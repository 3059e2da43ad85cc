// The error map (models/map, docs/map.md): the 21 errors with their bands, the error vectors on the working
// volume's faces, the volumetric accuracy, what the day could not determine, the cross-checks.
#include <cmath>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/number_format.hpp"
#include "models/map/map_json.hpp"
#include "models/map/volumetric.hpp"
#include "report/html.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"

namespace guideway::report {

namespace {

namespace mm = models::map;

std::string upper(int axis) { return std::string(1, "XYZ"[axis]); }

std::string what_of(int a, int c) {
  const auto role = mm::role_of(a, c);
  return mm::role_name(role) + " of " + upper(a) + (role == mm::Role::straightness ? " in " + mm::axis_name(c) : "");
}

std::string pm_html(double value, double u, const std::string& unit) {
  return html_escape((std::isfinite(u) && u > 0 ? with_uncertainty(value, u) : format_number(value, 4)) + " " + unit);
}

// An axis' three translations or three rotations along its travel, each with its +-2 u band.
std::string curves(const mm::ErrorMap& m, int a, bool rotations) {
  LinePlot p;
  const std::string unit = rotations ? "\u00b5rad" : "\u00b5m";
  p.title = upper(a) + (rotations ? ": rotations (roll, pitch, yaw)" : ": translations (positioning, straightness)");
  p.x_label = upper(a) + " / mm";
  p.y_label = (rotations ? "angle / " : "error / ") + unit;
  p.height = 280;
  const mm::Travel& t = m.travel[static_cast<std::size_t>(a)];
  const int n = 81;
  for (int k = 0; k < 3; ++k) {
    const int c = rotations ? 3 + k : k;
    const mm::ErrorFunction& f = m.function(a, c);
    Series s;
    s.label = mm::function_name(a, c) + " (" + mm::role_name(mm::role_of(a, c)) + ")";
    s.color = palette(static_cast<std::size_t>(k));
    Band b;
    b.color = s.color;
    if (!f.determined) {
      s.label += ": not determined";
      s.style = Style::dashed;
      s.width = 0.8;
    }
    for (int i = 0; i < n; ++i) {
      const double u = t.lo_m + t.length_m() * i / (n - 1);
      const double v = m.value(a, c, u) * 1e6;
      s.x.push_back(u * 1e3);
      s.y.push_back(f.determined ? v : std::nan(""));
      if (f.determined) {
        const double uu = m.uncertainty(a, c, u) * 1e6;
        b.x.push_back(u * 1e3);
        b.lo.push_back(v - 2 * uu);
        b.hi.push_back(v + 2 * uu);
      }
    }
    if (!f.determined) {
      // Drawn as a dashed zero line, so the legend says what is missing.
      for (auto& y : s.y) y = 0.0;
    }
    p.series.push_back(std::move(s));
    if (!b.x.empty()) p.bands.push_back(std::move(b));
  }
  if (!p.bands.empty()) p.bands.front().label = "\u00b12 u";
  return html_figure(render(p), html_escape(p.title + ": each function relative to the map's gauge (zero mean; a "
                                                      "straightness about its least-squares line), with its band of "
                                                      "twice its standard uncertainty"));
}

// The error vectors on three faces of the volume, relative to the best-fit rigid body (as the volumetric
// accuracy takes them).
std::string faces(const mm::ErrorMap& m) {
  const std::size_t g = 7;
  const auto at = mm::volume_grid(m.travel, {g, g, g});
  std::vector<mm::Vec3> e(at.size());
  for (std::size_t i = 0; i < at.size(); ++i) e[i] = mm::tool_error(m, at[i], m.tool_offset_m);
  const auto rel = mm::relative_to_rigid_body(at, e);
  std::ostringstream o;
  o << "<div class=\"figure-row\">";
  struct Face {
    int a, b, n;       // in-plane axes, normal
    std::size_t at;    // grid index of the face along the normal
    const char* name;  // which face
  };
  const Face faces[] = {{0, 1, 2, g - 1, "top (Z at its highest)"},
                        {0, 2, 1, 0, "front (Y at its lowest)"},
                        {1, 2, 0, g - 1, "side (X at its highest)"}};
  for (const Face& f : faces) {
    VectorField v;
    v.title = upper(f.a) + upper(f.b) + " face, " + f.name;
    v.x_label = upper(f.a) + " / mm";
    v.y_label = upper(f.b) + " / mm";
    v.w_label = upper(f.n) + " error / \u00b5m";
    for (std::size_t i = 0; i < at.size(); ++i) {
      const std::size_t k[3] = {i % g, (i / g) % g, i / (g * g)};
      if (k[f.n] != f.at) continue;
      v.x.push_back(at[i][static_cast<std::size_t>(f.a)] * 1e3);
      v.y.push_back(at[i][static_cast<std::size_t>(f.b)] * 1e3);
      v.u.push_back(rel[i][static_cast<std::size_t>(f.a)] * 1e6);
      v.v.push_back(rel[i][static_cast<std::size_t>(f.b)] * 1e6);
      v.w.push_back(rel[i][static_cast<std::size_t>(f.n)] * 1e6);
    }
    o << html_figure(render(v), html_escape(v.title + ": the tool point's error in the face's plane (arrows) and out "
                                                      "of it (colour), relative to the best-fit rigid body"));
  }
  o << "</div>";
  return o.str();
}

std::string errors_table(const mm::ErrorMap& m, const nlohmann::json& j) {
  Table t("The 21 errors (RMS and peak to valley over the travel; u: the RMS of the standard uncertainty)",
          {"error", "what", "RMS", "peak to valley", "u", "Legendre orders", "determined by"});
  t.text_columns = {1, 5, 6};
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < mm::components; ++c) {
      const mm::ErrorFunction& f = m.function(a, c);
      const std::string unit = c < 3 ? " \u00b5m" : " \u00b5rad";
      if (!f.determined) {
        t.rows.push_back({html_escape(mm::function_name(a, c)), html_escape(what_of(a, c)), "&ndash;", "&ndash;",
                          "&ndash;", "", "<em>not determined</em>"});
        continue;
      }
      const auto fig = mm::function_figures(m, a, c);
      std::string orders;
      for (int k : f.orders) orders += (orders.empty() ? "P" : ", P") + std::to_string(k);
      t.rows.push_back({html_escape(mm::function_name(a, c)), html_escape(what_of(a, c)),
                        html_escape(format_number(fig.rms * 1e6, 3) + unit),
                        html_escape(format_number(fig.peak_to_valley * 1e6, 3) + unit),
                        html_escape(format_number(fig.u_rms * 1e6, 2) + unit), html_escape(orders),
                        html_escape(f.determined_by)});
    }
  for (const auto& q : j["squareness"]) {
    const std::string what = "squareness " + q["plane"].get<std::string>() + " (ISO 230-1 sign)";
    if (!q["determined"].get<bool>()) {
      t.rows.push_back({html_escape(q["iso_name"].get<std::string>()), html_escape(what), "&ndash;", "", "&ndash;", "",
                        "<em>not determined</em>"});
      continue;
    }
    t.rows.push_back({html_escape(q["iso_name"].get<std::string>()), html_escape(what),
                      pm_html(q["iso_value_urad"].get<double>(), q["u_urad"].get<double>(), "\u00b5rad"), "", "", "",
                      html_escape(q["determined_by"].get<std::string>())});
  }
  return html_table(t);
}

std::string volumetric_html(const nlohmann::json& v) {
  const auto at = v["at_mm"], tool = v["tool_offset_mm"], err = v["error_at_um"];
  Table t("Volumetric accuracy", {"figure", "value"});
  t.text_columns = {1};
  t.rows.push_back({"largest error (E_VE)", pm_html(v["value_um"].get<double>(), v["u_um"].get<double>(), "\u00b5m")});
  t.rows.push_back({"where", html_escape("X " + format_number(at[0].get<double>(), 4) + ", Y " +
                                         format_number(at[1].get<double>(), 4) + ", Z " +
                                         format_number(at[2].get<double>(), 4) + " mm; error (" +
                                         format_number(err[0].get<double>(), 3) + ", " +
                                         format_number(err[1].get<double>(), 3) + ", " +
                                         format_number(err[2].get<double>(), 3) + ") \u00b5m")});
  t.rows.push_back({"E_VX, E_VY, E_VZ (ranges)", html_escape(format_number(v["E_VX_um"].get<double>(), 3) + ", " +
                                                             format_number(v["E_VY_um"].get<double>(), 3) + ", " +
                                                             format_number(v["E_VZ_um"].get<double>(), 3) + " \u00b5m")});
  t.rows.push_back({"RMS over the grid", html_escape(format_number(v["rms_um"].get<double>(), 3) + " \u00b5m")});
  t.rows.push_back({"grid, tool offset", html_escape(std::to_string(v["points"].get<std::size_t>()) + " points; tool " +
                                                     format_number(tool[0].get<double>(), 4) + ", " +
                                                     format_number(tool[1].get<double>(), 4) + ", " +
                                                     format_number(tool[2].get<double>(), 4) + " mm")});
  std::string html = html_table(t) + "<p>" + html_escape("Definition: " + v["definition"].get<std::string>() + ".") + "</p>";
  if (!v["missing"].empty()) {
    std::string m;
    for (const auto& x : v["missing"]) m += (m.empty() ? "" : ", ") + x.get<std::string>();
    html += html_note("Not the machine's figure: the tests did not determine " + m + ", which it leaves out.");
  }
  return html;
}

std::string checks_table(const nlohmann::json& j) {
  if (!j.contains("checks") || j["checks"].empty()) return "<p>No two tests of the day overlap.</p>";
  Table t("Cross-checks where tests overlap (consistent: the difference within twice its u)",
          {"quantity", "first test", "value", "second test", "value", "difference", "verdict"});
  t.text_columns = {1, 3, 6};
  for (const auto& c : j["checks"]) {
    const std::string unit = c["unit"].get<std::string>() == "um"     ? "\u00b5m"
                             : c["unit"].get<std::string>() == "urad" ? "\u00b5rad"
                                                                       : c["unit"].get<std::string>();
    t.rows.push_back({html_escape(c["name"].get<std::string>()), html_escape(c["first"].get<std::string>()),
                      pm_html(c["value_first"].get<double>(), c["u_first"].get<double>(), unit),
                      html_escape(c["second"].get<std::string>()),
                      pm_html(c["value_second"].get<double>(), c["u_second"].get<double>(), unit),
                      pm_html(c["difference"].get<double>(), c["u_difference"].get<double>(), unit),
                      c["consistent"].get<bool>() ? "consistent" : "<strong>not consistent</strong>"});
  }
  std::string notes;
  for (const auto& c : j["checks"])
    if (!c["consistent"].get<bool>()) notes += html_note(c["name"].get<std::string>() + ": " + c["note"].get<std::string>());
  return html_table(t) + notes;
}

std::string groups_table(const nlohmann::json& j) {
  Table t("The tests' readings about the map", {"test", "readings", "residual RMS", "noise (weight)"});
  for (const auto& g : j.value("groups", nlohmann::json::array())) {
    const std::string unit = g["unit"].get<std::string>() == "um" ? "\u00b5m" : "\u2033";
    t.rows.push_back({html_escape(g["test"].get<std::string>()), std::to_string(g["observations"].get<std::size_t>()),
                      html_escape(format_number(g["residual_rms"].get<double>(), 3) + " " + unit),
                      html_escape(format_number(g["sigma"].get<double>(), 3) + " " + unit)});
  }
  return html_table(t);
}

}  // namespace

std::string map_section(const nlohmann::json& j, const std::string& source, const std::string& id) {
  const mm::ErrorMap m = mm::map_from_json(j, source);
  std::ostringstream body;
  body << "<p>" << html_escape("One model of " + (m.machine.empty() ? std::string("the machine") : m.machine) +
                               " from the day's tests (docs/map.md): per axis its positioning, two straightnesses and "
                               "three angles as functions of its position, and the three squarenesses, through the "
                               "chain bed \u2192 " + upper(m.chain[0]) + " \u2192 " + upper(m.chain[1]) + " \u2192 " +
                               upper(m.chain[2]) + " \u2192 tool (tool offset " +
                               format_number(m.tool_offset_m[0] * 1e3, 4) + ", " +
                               format_number(m.tool_offset_m[1] * 1e3, 4) + ", " +
                               format_number(m.tool_offset_m[2] * 1e3, 4) + " mm).")
       << "</p>";
  nlohmann::json va;
  if (j.contains("volumetric")) {
    va = j["volumetric"];
  } else {
    va = mm::to_json(mm::volumetric_accuracy(m));
  }
  body << volumetric_html(va);
  body << errors_table(m, j);
  for (const auto& f : j["functions"])
    if (!f["determined"].get<bool>()) body << html_note(f["name"].get<std::string>() + ": " + f["why"].get<std::string>());
  for (const auto& q : j["squareness"])
    if (!q["determined"].get<bool>())
      body << html_note(q["iso_name"].get<std::string>() + " (squareness " + q["plane"].get<std::string>() +
                        "): " + q["why"].get<std::string>());
  body << "<h3>The error vectors over the volume</h3>" << faces(m);
  body << "<h3>The error functions</h3>";
  for (int a = 0; a < 3; ++a) body << curves(m, a, false) << curves(m, a, true);
  body << "<h3>Cross-checks</h3>" << checks_table(j);
  body << "<h3>The tests</h3>" << groups_table(j);
  for (const auto& n : j.value("notes", nlohmann::json::array())) body << html_note(n.get<std::string>());
  return html_section("map", id, "Error map: " + base_name(source), body.str());
}

std::string render_map_report(const nlohmann::json& map, const ReportOptions& options) {
  const std::string id = "map-1";
  try {
    const std::string html = map_section(map, map.value("machine", std::string("map")), id);
    return html_document(options.title, options.subtitle, {{id, "Error map"}}, html);
  } catch (const std::invalid_argument& e) {
    throw ReportError(e.what());
  }
}

}  // namespace guideway::report
