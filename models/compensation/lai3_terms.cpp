// Lai's third-order parameters as the compensation map's terms (compensation.hpp: lai3_terms, lai3_term_of).
#include <cmath>
#include <string>
#include <vector>

#include "core/number_format.hpp"
#include "models/compensation/compensation.hpp"
#include "models/compensation/compensation_common.hpp"
#include "results/parameters.hpp"

namespace guideway::models::compensation {

namespace {

using detail::find;

// Lai's parameters that feed the map: Lai's parameter, the map term (of plane axis `axis`, -1 for a term of
// the plane) and the factor from Lai's unit to the term's (r = the radius the straightness is normalised to).
struct LaiTerm {
  const results::Parameter* lai;
  const results::Parameter* term;
  int axis;
  int radius_power;  // the factor is scale * (r in mm)^radius_power
  double scale;
};
constexpr LaiTerm lai_terms[] = {
    {&results::lai_S_x, &results::scale, 0, 0, 1e6},
    {&results::lai_S_y, &results::scale, 1, 0, 1e6},
    {&results::backlash, &results::backlash, 0, 0, 1.0},  // Lai's backlash of axis a, b: backlash's place in lai3
    {&results::backlash, &results::backlash, 1, 0, 1.0},
    {&results::lai_a1, &results::squareness, -1, 0, 1e6},
    {&results::lai_a2, &results::straightness_bow, 0, 2, 1e3},  // a2 (1/mm) r^2 (mm^2) = mm
    {&results::lai_b2, &results::straightness_bow, 1, 2, 1e3},
    {&results::lai_a3, &results::straightness_cubic, 0, 3, 1e3},
    {&results::lai_b3, &results::straightness_cubic, 1, 3, 1e3},
    {&results::servo_mismatch, &results::servo_mismatch, -1, 0, 1.0},
};

// The name Lai's model reports the term by (its x and y are the plane's axes a and b, the term's `axis`).
std::string lai_name_of(const LaiTerm& t) { return results::name_in(*t.lai, results::lai3_group, "xy", t.axis); }

}  // namespace

std::string lai3_term_of(const std::string& lai_name, const std::string& plane) {
  for (const auto& t : lai_terms)
    if (lai_name_of(t) == lai_name) return results::name(*t.term, plane, t.axis);
  return "";
}

std::vector<dbb::Estimate> lai3_terms(const dbb::Identification& id, double radius_m, std::vector<std::string>& notes) {
  std::vector<dbb::Estimate> out;
  std::string missing;
  for (const auto& t : lai_terms) {
    const auto* e = find(id.lai3, lai_name_of(t));
    if (!e || !e->fitted) {
      missing += (missing.empty() ? "" : ", ") + lai_name_of(t);
      continue;
    }
    const double f = t.scale * std::pow(radius_m * 1e3, t.radius_power);
    const double v = t.lai == &results::lai_S_x || t.lai == &results::lai_S_y ? e->value - 1.0 : e->value;
    out.push_back({results::name(*t.term, id.plane, t.axis), v * f, e->u * f, true});
  }
  if (!missing.empty()) {
    std::string combos;
    for (const auto& c : id.fit.combinations) combos += (combos.empty() ? "" : ", ") + c.expression;
    notes.push_back("Lai's model could not separate " + missing + " with these runs, so the map has no such term" +
                    (combos.empty() ? std::string() : " (they determine only " + combos + ")") +
                    "; a pattern with h > 0 at another radius separates them (docs/conventions.md)");
  }
  // Both scales off by the same large amount is a radius change common to both axes (the position
  // loops' lag at the runs' feed, a bar calibration error), not the axes' own scales: the table takes
  // only their difference, as the identification's note for the diagnostics says.
  dbb::Estimate* sa = nullptr;
  dbb::Estimate* sb = nullptr;
  for (auto& e : out) {
    if (e.name == results::name(results::scale, id.plane, 0)) sa = &e;
    if (e.name == results::name(results::scale, id.plane, 1)) sb = &e;
  }
  if (sa && sb) {
    const double common = 0.5 * (sa->value + sb->value), mismatch = sa->value - sb->value;
    if (std::abs(common) > 50 && std::abs(common) > 3 * std::abs(mismatch)) {
      notes.push_back("both scales read about " + printf_number("%.0f", common) +
                      " ppm: a radius change common to both axes (a position loop's lag shrinks a circle by r "
                      "(omega tau)^2 / 2 at high feed; a bar calibration error), not the axes' own scales; the "
                      "tables hold only their difference (" +
                      printf_number("%.1f", mismatch) +
                      " ppm, split about zero): measure at a low feed for the scales themselves");
      sa->value -= common;
      sb->value -= common;
    }
  }
  std::string other;
  for (const auto& e : id.lai3)
    if (e.fitted && lai3_term_of(e.name, id.plane).empty() && !e.name.starts_with("e_x") &&
        !e.name.starts_with("e_y") && e.name != results::lai_mismatch_phase_angle.name)
      other += (other.empty() ? "" : ", ") + e.name;
  if (!other.empty())
    notes.push_back("not in the map: Lai's out-of-plane terms (" + other +
                    ": straightness along the plane normal, roll), which no table of the plane axes can hold");
  return out;
}

}  // namespace guideway::models::compensation
