// The text summary `guideway compensate` prints (compensation.hpp: to_text, left_out_in_words).
#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "core/number_format.hpp"
#include "core/printable.hpp"
#include "models/compensation/compensation.hpp"
#include "models/compensation/compensation_common.hpp"
#include "models/explain/dbb_explain.hpp"
#include "results/parameters.hpp"

namespace guideway::models::compensation {

namespace {

using detail::find;
using detail::letters_upper;

// Why the squareness is not entered as skew.
std::string squareness_left_out(const ErrorMap& m) {
  const auto* t = find(m.terms, results::name(results::squareness));
  const std::string why = t ? left_out_because(*t) : "";
  return why.empty() || why == "left out (not larger than 2 u)" ? "not significant" : why;
}

}  // namespace

std::string left_out_in_words(const Term& t, const ErrorMap& m) {
  const auto* explain = t.contradiction.starts_with("contradicts EXPLAIN") ? find(m.cross_check, t.name) : nullptr;
  if (!t.determined || !explain) return left_out_because(t);
  const results::Shown theirs = results::shown(t.name, explain->value, explain->u, m.plane);
  const double z = std::abs(t.value - explain->value) / std::hypot(t.u, explain->u);
  return "NOT WRITTEN: EXPLAIN finds " + theirs.value + (theirs.unit.empty() ? "" : " " + theirs.unit) +
         " on the same runs (" + printf_number("%.0f", z) + " combined u apart)";
}

std::string to_text(const ErrorMap& m) {
  std::ostringstream o;
  o << "compensation from "
    << (m.model == "lai3" ? "Lai's third-order model (lai3; terms named as the diagnostics')"
                          : "the ballbar diagnostics")
    << " (" << m.plane << " plane, table step " << printf_number("%.3g", m.step_m * 1e3) << " mm)\n";
  // Each term by its label, its value rounded to u in the unit it is shown in, and where it went.
  std::vector<std::array<std::string, 4>> rows{{"term", "value \u00b1 u", "", "use"}};
  for (const auto& t : m.terms) {
    std::string use = left_out_in_words(t, m);
    if (!use.empty())
      ;
    else if (t.use == Use::table)
      use = t.name.find("_" + m.axes[0].axis + "_") != std::string::npos ? m.axes[0].axis + ".comp"
                                                                         : m.axes[1].axis + ".comp";
    else
      use = (t.use == Use::map_only ? "errors.csv only: " : (t.use == Use::cross_table ? "" : "no table: ")) + t.why;
    results::Shown shown = results::shown(t.name, t.value, t.u, m.plane);
    if (!t.determined) {  // no number for what the runs do not determine (use says why)
      shown.value = "not determined";
      shown.unit.clear();
    }
    rows.push_back({shown.label, shown.value, shown.unit, use});
  }
  std::size_t label_w = 0, value_w = 0, unit_w = 0;
  for (const auto& r : rows) {
    label_w = std::max(label_w, display_width(r[0]));
    value_w = std::max(value_w, display_width(r[1]));
    unit_w = std::max(unit_w, display_width(r[2]));
  }
  for (const auto& r : rows)
    o << "  " << r[0] << std::string(label_w - display_width(r[0]) + 2, ' ')
      << std::string(value_w - display_width(r[1]), ' ') << r[1] << "  " << r[2]
      << std::string(unit_w - display_width(r[2]) + 2, ' ') << r[3] << "\n";
  for (const auto& am : m.axes)
    o << "  " << am.axis << ".comp: " << am.nominal_m.size() << " lines, "
      << printf_number("%.3f", am.nominal_m.front() * 1e3) << " .. " << printf_number("%.3f", am.nominal_m.back() * 1e3)
      << " mm\n";
  // The notes, but what was fitted beside in words and rounded to u (the files keep the names).
  for (const auto& n : m.notes)
    if (m.beside.empty() || !n.starts_with(explain::fitted_beside_note)) o << "note: " << n << "\n";
  if (!m.beside.empty()) {
    o << "note: " << explain::fitted_beside_note << " (what EXPLAIN found on the same runs; in no table):";
    for (std::size_t k = 0; k < m.beside.size(); ++k) {
      const auto& e = m.beside[k];
      const results::Shown s = results::shown(e.name, e.value, e.u, m.plane);
      o << (k ? ", " : " ") << s.label << " " << s.value << (s.unit.empty() ? "" : " " + s.unit);
    }
    o << "\n";
  }
  if (m.squareness_known) {
    const auto adv = squareness_advice(m.squareness_rad);
    const std::string a = m.axes[0].axis, b = m.axes[1].axis;
    o << "squareness " << a << b << ": " << with_uncertainty(adv.um_per_m, m.squareness_u_rad * 1e6)
      << " \u00b5m/m; correction " << printf_number("%+.3f", adv.correction_um_per_100mm) << " \u00b5m of "
      << letters_upper(a) << " per +100 mm of " << letters_upper(b)
      << (m.squareness_significant ? "" : " (" + squareness_left_out(m) + ": leave it)")
      << ". A per-joint table cannot hold it: set your controller's axis-skew correction, or change the kinematics\n";
  }
  return o.str();
}

}  // namespace guideway::models::compensation
