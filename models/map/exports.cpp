// What a controller loads from an error map (exports.hpp): the ISO 230-1-named tables, the LinuxCNC per-joint
// tables with their INI lines, the cross-axis straightness and the plain map.
#include "models/map/exports.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "core/number_format.hpp"
#include "formats/compensation_files.hpp"
#include "models/map/map_json.hpp"

namespace guideway::models::map {

namespace {

Vec3 middle(const ErrorMap& m) {
  Vec3 c{};
  for (std::size_t a = 0; a < 3; ++a) c[a] = 0.5 * (m.travel[a].lo_m + m.travel[a].hi_m);
  return c;
}

// Positions every step over the travel, both ends included (the last step may be shorter).
std::vector<double> stations(const Travel& t, double step) {
  std::vector<double> u;
  const auto n = static_cast<std::size_t>(std::ceil(t.length_m() / step - 1e-9));
  for (std::size_t k = 0; k < n; ++k) u.push_back(t.lo_m + static_cast<double>(k) * step);
  u.push_back(t.hi_m);
  return u;
}

std::string chain_text(const ErrorMap& m) {
  std::string s;
  for (int a : m.chain) s += axis_name(a);
  return s;
}

std::string mm_text(const Vec3& v) {
  return "[" + shortest(v[0] * 1e3) + ", " + shortest(v[1] * 1e3) + ", " + shortest(v[2] * 1e3) + "]";
}

// The tool point's error along axis j's line through the volume's centre.
Vec3 line_error(const ErrorMap& m, int j, double u) {
  Vec3 p = middle(m);
  p[static_cast<std::size_t>(j)] = u;
  return tool_error(m, p, m.tool_offset_m);
}

double interpolate(const std::vector<double>& at, const std::vector<double>& v, double x) {
  if (x <= at.front()) return v.front();
  if (x >= at.back()) return v.back();
  const auto hi = static_cast<std::size_t>(std::upper_bound(at.begin(), at.end(), x) - at.begin());
  const std::size_t lo = hi - 1;
  const double f = (x - at[lo]) / (at[hi] - at[lo]);
  return v[lo] + f * (v[hi] - v[lo]);
}

}  // namespace

double table_step_m(const ErrorMap& m, const ExportOptions& o) {
  double longest = 0;
  for (const auto& t : m.travel) longest = std::max(longest, t.length_m());
  const auto lines = [&](double step) { return static_cast<std::size_t>(std::ceil(longest / step - 1e-9)) + 1; };
  if (o.step_m != 0.0) {
    if (!std::isfinite(o.step_m) || !(o.step_m > 0)) throw std::invalid_argument("the table step must be positive");
    if (lines(o.step_m) > formats::linuxcnc_comp_max_lines)
      throw std::invalid_argument("a step of " + shortest(o.step_m * 1e3) + " mm gives " +
                                  std::to_string(lines(o.step_m)) + " lines over " + shortest(longest * 1e3) +
                                  " mm; LinuxCNC keeps at most 256 (use a coarser step)");
    return o.step_m;
  }
  for (double decade = 1e-4;; decade *= 10)
    for (double f : {5.0, 10.0, 20.0, 25.0})
      if (lines(decade * f) <= formats::linuxcnc_comp_max_lines) return decade * f;
}

formats::Iso230AxisTable iso230_table(const ErrorMap& m, int axis, double step_m) {
  formats::Iso230AxisTable t;
  t.axis = static_cast<char>('x' + axis);
  for (double u : stations(m.travel[static_cast<std::size_t>(axis)], step_m)) {
    t.position_mm.push_back(u * 1e3);
    for (int c = 0; c < components; ++c) t.values[static_cast<std::size_t>(c)].push_back(m.value(axis, c, u) * 1e6);
  }
  t.metadata = {{"machine", m.machine},
                {"chain", chain_text(m)},
                {"tool_offset_mm", mm_text(m.tool_offset_m)},
                {"unit_position", "mm"},
                {"unit_translation", "um"},
                {"unit_rotation", "urad"}};
  return t;
}

formats::Iso230Squareness iso230_squareness(const ErrorMap& m) {
  formats::Iso230Squareness q;
  q.ec0y_urad = iso_squareness_sign(0) * m.squareness[0].value_rad * 1e6;
  q.eb0z_urad = iso_squareness_sign(1) * m.squareness[1].value_rad * 1e6;
  q.ea0z_urad = iso_squareness_sign(2) * m.squareness[2].value_rad * 1e6;
  q.metadata = {{"machine", m.machine}, {"chain", chain_text(m)}};
  return q;
}

std::vector<std::string> map_export_names() {
  return {"iso230_x.csv", "iso230_y.csv",   "iso230_z.csv",     "iso230_squareness.csv", "x.comp",
          "y.comp",       "z.comp",         "linuxcnc.ini",     "straightness.csv",      "map_functions.csv"};
}

std::vector<ExportFile> map_exports(const ErrorMap& m, const std::vector<AxisBacklash>& backlash,
                                    const ExportOptions& o, const std::string& source) {
  const double step = table_step_m(m, o);
  std::vector<ExportFile> out;
  std::vector<std::string> missing;
  for (const auto& axis : m.functions)
    for (const auto& f : axis)
      if (!f.determined) missing.push_back(function_name(f.axis, f.component));
  for (const auto& q : m.squareness)
    if (!q.determined) missing.push_back("squareness " + q.plane);
  std::string missing_text;
  for (const auto& n : missing) missing_text += (missing_text.empty() ? "" : ", ") + n;
  const std::vector<std::string> header = {
      "error map " + source + " (guideway map export; docs/map.md)",
      "the map's chain from the bed up: " + chain_text(m) + "; tool offset " + mm_text(m.tool_offset_m) + " mm",
      missing.empty() ? "every term determined" : "not determined by the day's tests (written as 0): " + missing_text};

  // The volumetric compensation's tables.
  for (int a = 0; a < 3; ++a) {
    std::vector<std::string> c = header;
    c.push_back("positions every " + shortest(step * 1e3) +
                " mm; each function relative to the map's gauge (docs/map.md): zero mean, straightness about its "
                "least-squares line");
    out.push_back({"iso230_" + axis_name(a) + ".csv", formats::format_iso230_axis_table(iso230_table(m, a, step), c)});
  }
  {
    std::vector<std::string> c = header;
    c.push_back("ISO 230-1 signs: EC0Y = -(Y leaning towards +x), EB0Z = +(Z towards +x), EA0Z = -(Z towards +y)");
    out.push_back({"iso230_squareness.csv", formats::format_iso230_squareness(iso230_squareness(m), c)});
  }

  // LinuxCNC: per joint the error along its line through the volume's centre, the backlash in the columns.
  const Vec3 mid = middle(m);
  std::vector<formats::IniJoint> joints;
  std::vector<formats::CrossCorrectionRow> cross;  // per moving axis, per corrected axis, ascending
  for (int a = 0; a < 3; ++a) {
    double b = 0;
    std::string b_from = "no ballbar plane saw its backlash: forward = reverse";
    for (const auto& x : backlash)
      if (x.axis == a && x.value_m > 2 * x.u_m) {
        b = x.value_m;
        b_from = "backlash " + with_uncertainty(x.value_m * 1e6, x.u_m * 1e6) + " um from " + x.from;
      }
    std::vector<formats::CompTriplet> table;
    const auto at = stations(m.travel[static_cast<std::size_t>(a)], step);
    for (double u : at) {
      const Vec3 e = line_error(m, a, u);
      const double actual = u + e[static_cast<std::size_t>(a)];
      table.push_back({u * 1e3, (actual - 0.5 * b) * 1e3, (actual + 0.5 * b) * 1e3});
    }
    for (int i = 0; i < 3; ++i)
      if (i != a)
        for (double u : at)
          cross.push_back({axis_name(a), u * 1e3, axis_name(i), -line_error(m, a, u)[static_cast<std::size_t>(i)] * 1e3});
    std::vector<std::string> c = header;
    c.push_back("joint " + std::to_string(a) + " (" + axis_name(a) + "): the actual position along " + axis_name(a) +
                " on its line through the volume's centre " + mm_text(mid) + " mm, moving + and moving -; " + b_from);
    out.push_back({axis_name(a) + ".comp", formats::format_linuxcnc_comp(table, c)});
    joints.push_back({a, axis_name(a), axis_name(a) + ".comp"});
  }
  {
    std::vector<std::string> c = header;
    c.push_back("A per-joint table corrects each axis along its own line through the volume's centre. What it cannot");
    c.push_back("hold: the straightness of each line (straightness.csv, for a controller's cross-axis compensation),");
    c.push_back("and the angular errors' Abbe terms away from the centre lines (only the volumetric tables");
    c.push_back("iso230_*.csv hold them; docs/map.md, docs/linuxcnc.md).");
    out.push_back({"linuxcnc.ini", formats::format_linuxcnc_ini(joints, c)});
  }
  {
    std::vector<std::string> c = header;
    c.push_back("the correction of the corrected axis' command by the moving axis' position: minus the error across");
    c.push_back("each axis' line through the volume's centre (with its squareness there)");
    out.push_back({"straightness.csv",
                   formats::format_straightness_csv(cross, {{"source", source}, {"machine", m.machine}}, c)});
  }
  {
    std::ostringstream csv;
    csv << "# format = guideway/map-functions/1\n# source = " << source << "\n";
    for (const auto& l : header) csv << "# " << l << "\n";
    csv << "function,axis,role,position_mm,value,u,unit,determined_by\n";
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < components; ++c) {
        const ErrorFunction& f = m.function(a, c);
        if (!f.determined) continue;
        for (double u : stations(m.travel[static_cast<std::size_t>(a)], step))
          csv << function_name(a, c) << "," << axis_name(a) << "," << role_name(role_of(a, c)) << ","
              << shortest(u * 1e3) << "," << shortest(m.value(a, c, u) * 1e6) << ","
              << shortest(m.uncertainty(a, c, u) * 1e6) << "," << (c < 3 ? "um" : "urad") << ",\""
              << f.determined_by << "\"\n";
      }
    out.push_back({"map_functions.csv", csv.str()});
  }
  return out;
}

TableMap read_table_map(const std::string& dir) {
  const std::filesystem::path d(dir);
  TableMap t;
  for (int a = 0; a < 3; ++a) {
    const std::string path = (d / ("iso230_" + axis_name(a) + ".csv")).string();
    t.axes[static_cast<std::size_t>(a)] = formats::read_iso230_axis_table(path);
    if (t.axes[static_cast<std::size_t>(a)].axis != 'x' + a)
      throw formats::Iso230TableError(path + ": a table of axis " + std::string(1, t.axes[static_cast<std::size_t>(a)].axis));
    for (const auto& [k, v] : t.axes[static_cast<std::size_t>(a)].metadata)
      if (k == "chain") {
        if (v.size() != 3) throw formats::Iso230TableError(path + ": chain must name the three axes from the bed up");
        for (std::size_t i = 0; i < 3; ++i) {
          const int c = v[i] - 'x';
          if (c < 0 || c > 2) throw formats::Iso230TableError(path + ": chain must name the three axes from the bed up");
          t.chain[i] = c;
        }
      }
  }
  t.squareness = formats::read_iso230_squareness((d / "iso230_squareness.csv").string());
  return t;
}

Vec3 table_tool_error(const TableMap& t, const Vec3& p, const Vec3& tool) {
  Vec3 e{};
  for (int j = 0; j < 3; ++j) {
    const auto& tab = t.axes[static_cast<std::size_t>(j)];
    const double u_mm = p[static_cast<std::size_t>(j)] * 1e3;
    double v[6];
    for (std::size_t c = 0; c < 6; ++c) v[c] = interpolate(tab.position_mm, tab.values[c], u_mm) * 1e-6;
    const Vec3 arm = rotation_arm(t.chain, j, p, tool);
    e[0] += v[0] + v[4] * arm[2] - v[5] * arm[1];
    e[1] += v[1] + v[5] * arm[0] - v[3] * arm[2];
    e[2] += v[2] + v[3] * arm[1] - v[4] * arm[0];
  }
  // ISO signs back to the map's leans: x += q_xy y + q_xz z, y += q_yz z.
  const double qxy = -t.squareness.ec0y_urad * 1e-6, qxz = t.squareness.eb0z_urad * 1e-6,
               qyz = -t.squareness.ea0z_urad * 1e-6;
  e[0] += qxy * p[1] + qxz * p[2];
  e[1] += qyz * p[2];
  return e;
}

}  // namespace guideway::models::map
