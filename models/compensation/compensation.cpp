// Compensation from a DBB identification (compensation.hpp): the plane axes' error maps, the squareness, the
// controller's files.
#include "models/compensation/compensation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <span>
#include <sstream>
#include <string_view>

#include "core/number_format.hpp"
#include "core/printable.hpp"
#include "formats/compensation_files.hpp"
#include "models/dbb/geometry.hpp"
#include "models/explain/dbb_explain.hpp"
#include "results/parameters.hpp"

namespace guideway::models::compensation {

namespace {

constexpr double pi = std::numbers::pi;
// A term is applied when it exceeds k standard uncertainties (k = 2, the usual expanded uncertainty):
// a correction smaller than that is mostly noise (an amplitude such as the cyclic error's is positive
// even when there is none, about 1.25 u on average).
constexpr double significance_k = 2.0;

// The item named `name` (an estimate, a term), nullptr for none.
template <class Named>
const Named* find(const std::vector<Named>& items, const std::string& name) {
  for (const auto& e : items)
    if (e.name == name) return &e;
  return nullptr;
}

const dbb::Estimate* find(const dbb::Identification& id, const std::string& name) { return find(id.diagnostics, name); }

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
    {&results::lai_backlash_x, &results::backlash, 0, 0, 1.0},
    {&results::lai_backlash_y, &results::backlash, 1, 0, 1.0},
    {&results::lai_a1, &results::squareness, -1, 0, 1e6},
    {&results::lai_a2, &results::straightness_bow, 0, 2, 1e3},  // a2 (1/mm) r^2 (mm^2) = mm
    {&results::lai_b2, &results::straightness_bow, 1, 2, 1e3},
    {&results::lai_a3, &results::straightness_cubic, 0, 3, 1e3},
    {&results::lai_b3, &results::straightness_cubic, 1, 3, 1e3},
    {&results::lai_servo_mismatch, &results::servo_mismatch, -1, 0, 1.0},
};

// The table steps offered by default (mm): a round spacing a user can read.
constexpr double default_steps_mm[] = {0.1, 0.2, 0.25, 0.5, 1, 2, 2.5, 5, 10, 20, 25, 50, 100};

// Counted in double: a step far below the range (1e-300 mm) gives a count no integer type holds.
double lines_for(double lo, double hi, double step) {
  const double first = std::floor(lo / step + 1e-9);
  const double last = std::ceil(hi / step - 1e-9);
  return last - first + 1;
}

// Machine coordinates this far from zero are a typing error, not a machine (and would print as
// hundreds of digits in the tables).
constexpr double max_machine_coordinate_m = 1000.0;

// The difference of the two plane axes' cubic straightness, Lai's a3 - b3 (per mm^2): an in-plane circle
// determines only that (a3 s c^3 + b3 c s^3 = (a3 + b3) sin 2 theta / 4 + (a3 - b3) sin 4 theta / 8, the
// first part reads as squareness), fitted alone or reported as the fit's combination of the two.
std::optional<dbb::Estimate> cubic_difference(const dbb::Identification& id) {
  const dbb::Estimate *a3 = nullptr, *b3 = nullptr;
  for (const auto& e : id.lai3) {
    if (e.name == results::lai_a3.name) a3 = &e;
    if (e.name == results::lai_b3.name) b3 = &e;
  }
  if (a3 && b3 && a3->fitted && b3->fitted)
    return dbb::Estimate{"a3_minus_b3", a3->value - b3->value, std::hypot(a3->u, b3->u), true};
  for (const auto& c : id.fit.combinations) {
    if (c.coefficient.size() != 2 || std::abs(c.coefficient[1] + 1.0) > 1e-6) continue;
    const std::string kept = c.expression.substr(0, c.expression.find(' '));
    const std::string other = c.expression.substr(c.expression.rfind('*') + 1);
    if (kept == results::lai_a3.name && other == results::lai_b3.name)
      return dbb::Estimate{"a3_minus_b3", c.value, c.u, true};
    if (kept == results::lai_b3.name && other == results::lai_a3.name)
      return dbb::Estimate{"a3_minus_b3", -c.value, c.u, true};
  }
  return std::nullopt;
}

std::string estimate_text(const Term& t) {
  if (!t.determined) return t.name + " not determined";
  return t.name + " = " + printf_number("%.4g", t.value) + " +/- " + printf_number("%.2g", t.u);
}

}  // namespace

double AxisTerms::cyclic_m(double position_m) const {
  if (cyclic_amplitude_m == 0.0 || !(cyclic_period_m > 0.0)) return 0.0;
  return cyclic_amplitude_m * std::sin(2 * pi * position_m / cyclic_period_m + cyclic_phase_rad);
}

double AxisTerms::positioning_error_m(double position_m, int direction) const {
  return scale * (position_m - center_m) - 0.5 * backlash_m * direction + cyclic_m(position_m);
}

double AxisTerms::straightness_m(double position_m) const {
  if (!(radius_m > 0)) return 0.0;
  const double d = position_m - center_m, q = d / radius_m;
  return bow_m * q * q + cubic_per_m2 * d * d * d;
}

std::string lai3_term_of(const std::string& lai_name, const std::string& plane) {
  for (const auto& t : lai_terms)
    if (lai_name == t.lai->name) return results::name(*t.term, plane, t.axis);
  return "";
}

std::vector<dbb::Estimate> lai3_terms(const dbb::Identification& id, double radius_m, std::vector<std::string>& notes) {
  std::vector<dbb::Estimate> out;
  std::string missing;
  for (const auto& t : lai_terms) {
    const auto* e = find(id.lai3, std::string(t.lai->name));
    if (!e || !e->fitted) {
      missing += (missing.empty() ? "" : ", ") + std::string(t.lai->name);
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

int joint_of(const std::string& axis) { return axis == "x" ? 0 : (axis == "y" ? 1 : 2); }

std::optional<std::array<double, 2>> runs_center_m(const std::vector<formats::DbbRun>& runs) {
  std::optional<std::array<double, 2>> c;
  for (const auto& r : runs) {
    if (!r.metadata.contains("center_a_mm") || !r.metadata.contains("center_b_mm")) return std::nullopt;
    const std::array<double, 2> rc{r.center_a_m, r.center_b_m};
    // The daemon's runs carry the centre the encoders traced, which differs between runs by the
    // errors it is measuring (um): one set-up within 10 um; simulated runs agree exactly.
    if (c && (std::abs((*c)[0] - rc[0]) > 1e-5 || std::abs((*c)[1] - rc[1]) > 1e-5))
      throw CompensationError(r.source + ": circle centre (" + shortest(rc[0] * 1e3) + ", " + shortest(rc[1] * 1e3) +
                              ") mm differs from the other runs' (" + shortest((*c)[0] * 1e3) + ", " +
                              shortest((*c)[1] * 1e3) + ") mm: one table needs one set-up");
    c = rc;
  }
  return c;
}

namespace {

void require_both_directions(const std::vector<formats::DbbRun>& runs) {
  const bool ccw =
      std::any_of(runs.begin(), runs.end(), [](const auto& r) { return r.direction == formats::DbbDirection::ccw; });
  const bool cw =
      std::any_of(runs.begin(), runs.end(), [](const auto& r) { return r.direction == formats::DbbDirection::cw; });
  if (!ccw || !cw)
    throw CompensationError(
        "the runs go one way only: in one direction backlash, lateral play and servo mismatch trade off against each "
        "other and squareness is not separable (docs/conventions.md); measure the circle in both directions");
}

// "diagnostics" when the identification has them, else "lai3" when Lai's model gave the scale or the
// backlash; throws when it has neither.
std::string map_model(const dbb::Identification& id) {
  if (find(id, results::name(results::scale, id.plane, 0)) && find(id, results::name(results::backlash, id.plane, 0)))
    return "diagnostics";
  if (!find(id.lai3, results::name(results::lai_S_x)) && !find(id.lai3, results::name(results::lai_backlash_x))) {
    std::string why =
        "the runs gave neither ballbar diagnostics nor Lai's scale and backlash, which the "
        "compensation is built from";
    for (const auto& n : id.notes) why += "; " + n;
    throw CompensationError(why + " (measure an in-plane circle, height 0, in both directions)");
  }
  return "lai3";
}

// The radius the map covers: the runs' one circle (diagnostics), the largest of them (Lai's polynomials hold
// over every run's circle); the runs become the map's sources.
double map_radius(const std::vector<formats::DbbRun>& runs, ErrorMap& m) {
  double radius = runs.front().radius_m;
  for (const auto& r : runs) {
    if (m.model == "lai3") radius = std::max(radius, r.radius_m);
    if (m.model != "lai3" && std::abs(r.radius_m - radius) > 1e-9)
      throw CompensationError(r.source + ": radius " + shortest(r.radius_m * 1e3) +
                              " mm differs from the other runs'; give the runs of one circle");
    m.sources.push_back(r.source);
  }
  return radius;
}

// The term `name` as checked: whether it is significant, whether the runs can have determined it, and
// whether it contradicts the map's cross-check (EXPLAIN's value of it).
Term checked(const ErrorMap& m, const std::string& name, double value, double u, Use use, const std::string& why) {
  Term t;
  t.name = name;
  t.value = value;
  t.u = u;
  t.use = use;
  t.why = why;
  t.significant = std::abs(t.value) > significance_k * t.u;
  t.determined = determined(t.name, t.value, t.u, m.circular_deviation_um, m.terms_of[0].radius_m, m.feed_m_per_s);
  if (t.determined) t.contradiction = explain::contradiction({name, value, u, true}, m.cross_check);
  return t;
}

// The identified term `name` into the map's terms with its use (nullptr when it was not fitted); applied
// when Term::applied(). m.terms is reserved: the pointer stays valid while the map is built.
const Term* take_term(ErrorMap& m, const std::vector<dbb::Estimate>& estimates, const std::string& name, Use use,
                      const std::string& why) {
  const auto* e = find(estimates, name);
  if (!e || !e->fitted || !std::isfinite(e->u)) return nullptr;
  m.terms.push_back(checked(m, name, e->value, e->u, use, why));
  return &m.terms.back();
}

// Plane axis k's positioning terms (scale, backlash, cyclic error) and its straightness across (bow, and
// its own cubic when Lai's model over several radii gives one: C = a3 r^3 at the map's radius); returns
// whether it had a cubic of its own.
bool axis_terms(ErrorMap& m, const std::vector<dbb::Estimate>& estimates, int k, double center_m, double radius) {
  const std::string ax = results::axis_letter(m.plane, k), other = results::axis_letter(m.plane, 1 - k);
  AxisTerms& at = m.terms_of[static_cast<std::size_t>(k)];
  at.center_m = center_m;
  at.radius_m = radius;
  const auto name = [&](const results::Parameter& p) { return results::name(p, m.plane, k); };
  const auto term = [&](const results::Parameter& p, Use use, const std::string& why) {
    return take_term(m, estimates, name(p), use, why);
  };
  if (const auto* t = term(results::scale, Use::table, ""); t && t->applied()) at.scale = t->value * 1e-6;
  if (const auto* t = term(results::backlash, Use::table, ""); t && t->applied()) at.backlash_m = t->value * 1e-6;
  if (const auto* t = term(results::cyclic_error, Use::table, ""); t && t->applied()) {
    const auto* p = find(estimates, name(results::cyclic_period));
    const auto* ph = find(estimates, name(results::cyclic_phase));
    if (p && ph) {
      at.cyclic_amplitude_m = t->value * 1e-6;
      at.cyclic_period_m = p->value * 1e-3;
      at.cyclic_phase_rad = ph->value * pi / 180;
    }
  }
  if (const auto* t =
          term(results::straightness_bow, Use::cross_table,
               "moves " + ax + " along " + other + ", which a per-joint table of " + ax +
                   " cannot: the cross-axis correction of " + other + " by " + ax + "'s position (straightness.csv)");
      t && t->applied())
    at.bow_m = t->value * 1e-6;
  const auto* cubic =
      term(results::straightness_cubic, Use::cross_table,
           "the cubic part of " + ax + "'s straightness along " + other + ": the cross-axis correction of " + other +
               " by " + ax + "'s position (straightness.csv)");
  if (cubic && cubic->applied()) at.cubic_per_m2 = cubic->value * 1e-6 / (radius * radius * radius);
  return cubic != nullptr;
}

// The cubic straightness one circle gives, in um at its radius: (a3 - b3) r^3, half of it given to each
// axis with opposite signs (what the circle sees of it; the rest is invisible to a circle of this radius).
void split_cubic_difference(ErrorMap& m, const dbb::Identification& id, double radius) {
  const auto cubic = cubic_difference(id);
  if (!cubic) return;
  const std::string A = results::axis_letter(m.plane, 0), B = results::axis_letter(m.plane, 1);
  const double r_mm = radius * 1e3;
  const double per_mm2_to_um = r_mm * r_mm * r_mm * 1e3;
  const dbb::Estimate e{results::name(results::straightness_cubic_difference, m.plane), cubic->value * per_mm2_to_um,
                        cubic->u * per_mm2_to_um, true};
  const Term t = checked(m, e.name, e.value, e.u, Use::cross_table,
                         "the cubic straightness of " + A + " along " + B + " less that of " + B + " along " + A +
                             " at the radius (Lai's a3 - b3); split evenly between the two cross-axis corrections "
                             "(straightness.csv)");
  m.terms.push_back(t);
  if (t.applied()) {
    // displacement = k d^3 with k in 1/m^2: (a3 - b3) / 2 per mm^2 is 1e6 times that per m^2.
    m.terms_of[0].cubic_per_m2 = 0.5 * cubic->value * 1e6;
    m.terms_of[1].cubic_per_m2 = -0.5 * cubic->value * 1e6;
  }
}

// The squareness (in the map, for the controller's axis skew) and what no position table can correct.
void plane_terms(ErrorMap& m, const std::vector<dbb::Estimate>& estimates) {
  if (const auto* t = take_term(m, estimates, results::name(results::squareness), Use::map_only,
                                "depends on the position of the other axis: set the controller's axis-skew correction "
                                "or a kinematics change (errors.csv)")) {
    m.squareness_known = true;
    m.squareness_rad = t->value * 1e-6;
    m.squareness_u_rad = t->u * 1e-6;
    m.squareness_significant = t->applied();
  }
  for (int k = 0; k < 2; ++k) {
    take_term(m, estimates, results::name(results::lateral_play, m.plane, k), Use::not_geometric,
              "a sideways shift that follows the direction of " + results::axis_letter(m.plane, k) +
                  ": a per-joint table of the other axis cannot see that direction (gib adjustment)");
    take_term(m, estimates, results::name(results::reversal_spike, m.plane, k), Use::not_geometric,
              "friction at the reversal, decays in milliseconds: servo tuning (friction feed-forward), not a table");
  }
  take_term(m, estimates, results::name(results::servo_mismatch), Use::not_geometric,
            "the two position loops lag differently: match their gains (or feed-forward); a position table cannot");
}

// The table spacing: the one asked for (refused when it gives too many lines), else the finest default
// step within LinuxCNC's lines over the measured range of both axes.
double table_step(const MapOptions& options, const std::array<double, 2>& center, double radius) {
  const auto lines_max = [&](double s) {
    return std::max(lines_for(center[0] - radius, center[0] + radius, s),
                    lines_for(center[1] - radius, center[1] + radius, s));
  };
  double step = options.step_m;
  if (step > 0) {
    // The tables cover centre +- radius: a step over the radius leaves fewer than three lines across the
    // circle (1e300 mm wrote a one-line table of nothing).
    if (step > radius)
      throw CompensationError("a step of " + shortest(step * 1e3) + " mm is over the circle's radius of " +
                              shortest(radius * 1e3) +
                              " mm: the tables cover centre +- radius with at least three lines (use a finer "
                              "--step-mm)");
    if (lines_max(step) > formats::linuxcnc_comp_max_lines)
      throw CompensationError("a step of " + shortest(step * 1e3) + " mm gives " + shortest(lines_max(step)) +
                              " lines over the measured range; LinuxCNC reads at most " +
                              std::to_string(formats::linuxcnc_comp_max_lines) +
                              " per joint (use a coarser --step-mm)");
    return step;
  }
  for (double s_mm : default_steps_mm) {
    step = s_mm * 1e-3;
    if (lines_max(step) <= formats::linuxcnc_comp_max_lines) break;
  }
  return step;
}

// Plane axis k's errors on the table's grid: the measured range on multiples of the step.
void fill_axis_map(ErrorMap& m, int k, double radius) {
  const double step = m.step_m;
  auto& at = m.terms_of[static_cast<std::size_t>(k)];
  if (at.cyclic_period_m > 0) {
    const double x = pi * step / at.cyclic_period_m;
    at.cyclic_table_gain = step < 0.5 * at.cyclic_period_m ? std::pow(x / std::sin(x), 2) : 0.0;
  }
  AxisMap& am = m.axes[static_cast<std::size_t>(k)];
  am.axis = results::axis_letter(m.plane, k);
  am.across = results::axis_letter(m.plane, 1 - k);
  const double first = std::floor((at.center_m - radius) / step + 1e-9);
  // at most linuxcnc_comp_max_lines here (table_step)
  const auto n = static_cast<std::size_t>(lines_for(at.center_m - radius, at.center_m + radius, step));
  for (std::size_t i = 0; i < n; ++i) {
    const double u = (first + static_cast<double>(i)) * step;
    am.nominal_m.push_back(u);
    am.forward_m.push_back(at.positioning_error_m(u, +1));
    am.reverse_m.push_back(at.positioning_error_m(u, -1));
    am.straightness_m.push_back(at.straightness_m(u));
    am.straightness_applied = at.bow_m != 0.0 || at.cubic_per_m2 != 0.0;
    const double extra = (at.cyclic_table_gain - 1.0) * at.cyclic_m(u);
    am.table_forward_m.push_back(am.forward_m.back() + extra);
    am.table_reverse_m.push_back(am.reverse_m.back() + extra);
  }
}

}  // namespace

std::array<double, 2> check_map_inputs(const std::vector<formats::DbbRun>& runs, const MapOptions& options) {
  if (runs.empty()) throw CompensationError("no runs");
  require_both_directions(runs);
  const auto center = options.center_m ? options.center_m : runs_center_m(runs);
  if (!center)
    throw CompensationError(
        "the circle centre in machine coordinates is not known: the run files carry no center_a_mm / center_b_mm "
        "metadata; give it with --center-mm X Y (the table positions are machine positions)");
  for (const double c : *center)
    if (!std::isfinite(c) || std::abs(c) > max_machine_coordinate_m)
      throw CompensationError("the circle centre " + shortest((*center)[0] * 1e3) + ", " +
                              shortest((*center)[1] * 1e3) + " mm is not a machine position (finite, within ±" +
                              shortest(max_machine_coordinate_m * 1e3) + " mm)");
  if (options.step_m != 0.0 && !(std::isfinite(options.step_m) && options.step_m > 0.0))
    throw CompensationError("the table step " + shortest(options.step_m * 1e3) + " mm is not a positive number");
  double radius = 0;  // the largest: what any map of these runs covers at most
  for (const auto& r : runs) radius = std::max(radius, r.radius_m);
  table_step(options, *center, radius);
  return *center;
}

ErrorMap error_map(const dbb::Identification& id, const std::vector<formats::DbbRun>& runs, const MapOptions& options) {
  const std::array<double, 2> center = check_map_inputs(runs, options);
  ErrorMap m;
  m.plane = id.plane;
  m.model = map_model(id);
  const double radius = map_radius(runs, m);
  const std::vector<dbb::Estimate> estimates = m.model == "lai3" ? lai3_terms(id, radius, m.notes) : id.diagnostics;
  if (const auto* g = find(id, results::name(results::circular_deviation))) m.circular_deviation_um = g->value;
  for (const auto& r : runs) m.feed_m_per_s = std::max(m.feed_m_per_s, r.feed_m_per_s);
  m.cross_check = options.cross_check;
  m.terms.reserve(24);
  bool cubic_per_axis = false;
  for (int k = 0; k < 2; ++k)
    cubic_per_axis = axis_terms(m, estimates, k, center[static_cast<std::size_t>(k)], radius) || cubic_per_axis;
  if (!cubic_per_axis) split_cubic_difference(m, id, radius);
  plane_terms(m, estimates);
  m.step_m = table_step(options, center, radius);
  for (int k = 0; k < 2; ++k) fill_axis_map(m, k, radius);
  return m;
}

ErrorMap error_map(const explain::CheckedIdentification& checked, const std::vector<formats::DbbRun>& runs,
                   MapOptions options) {
  options.cross_check = checked.explain;
  ErrorMap m = error_map(checked.id, runs, options);
  m.notes.insert(m.notes.end(), checked.notes.begin(), checked.notes.end());
  m.beside = checked.id.beside;
  return m;
}

bool spike_from_backlash_step(const ErrorMap& map, const dbb::Estimate& before, const dbb::Estimate& after) {
  for (int axis = 0; axis < 2; ++axis) {
    if (after.name != results::name(results::reversal_spike, map.plane, axis)) continue;
    const Term* backlash = find(map.terms, results::name(results::backlash, map.plane, axis));
    return backlash && backlash->applied() && before.fitted && !(std::abs(before.value) > significance_k * before.u) &&
           after.fitted && std::isfinite(after.u) && after.value < -significance_k * after.u;
  }
  return false;
}

std::string left_out_in_words(const Term& t, const ErrorMap& m) {
  const auto* explain = t.contradiction.starts_with("contradicts EXPLAIN") ? find(m.cross_check, t.name) : nullptr;
  if (!t.determined || !explain) return left_out_because(t);
  const results::Shown theirs = results::shown(t.name, explain->value, explain->u, m.plane);
  const double z = std::abs(t.value - explain->value) / std::hypot(t.u, explain->u);
  return "NOT WRITTEN: EXPLAIN finds " + theirs.value + (theirs.unit.empty() ? "" : " " + theirs.unit) +
         " on the same runs (" + printf_number("%.0f", z) + " combined u apart)";
}

std::string left_out_because(const Term& t) {
  if (!t.determined) return "not determined by these runs";
  if (!t.contradiction.empty()) return "NOT WRITTEN: " + t.contradiction;
  if (!t.significant) return "left out (not larger than 2 u)";
  return "";
}

SquarenessAdvice squareness_advice(double squareness_rad) {
  // actual a = a + q b: to land on the nominal a, command a - q b, i.e. -q * 100 mm per +100 mm of b.
  return {squareness_rad * 1e6, -squareness_rad * 0.1 * 1e6};
}

namespace {

std::vector<std::string> header_lines(const ErrorMap& m, const std::string& source) {
  std::vector<std::string> h;
  h.push_back("written by guideway compensate from " + source + "; error model: " + m.model +
              (m.model == "lai3" ? " (Lai's third-order model, its terms named as the diagnostics')"
                                 : " (the ballbar diagnostics)"));
  const auto& t0 = m.terms_of[0];
  h.push_back("measured circle: centre (" + printf_number("%.3f", t0.center_m * 1e3) + ", " +
              printf_number("%.3f", m.terms_of[1].center_m * 1e3) + ") mm in the " + m.plane + " plane, radius " +
              printf_number("%.3f", t0.radius_m * 1e3) +
              " mm; valid only over that range, in that plane and at that height");
  h.push_back("positions are relative to the axis' position at the circle centre (a DBB sees no constant offset)");
  std::string applied, left_out, undetermined, contradicted;
  for (const auto& t : m.terms) {
    if (t.use == Use::not_geometric) continue;
    const auto add = [&](std::string& list, const std::string& text) { list += (list.empty() ? "" : ", ") + text; };
    if (t.applied())
      add(applied, estimate_text(t));
    else if (!t.determined)
      add(undetermined, t.name);
    else if (!t.contradiction.empty())
      add(contradicted, estimate_text(t) + " (" + t.contradiction + ")");
    else
      add(left_out, estimate_text(t));
  }
  h.push_back("identified (value +/- standard uncertainty): " + (applied.empty() ? std::string("none") : applied));
  h.push_back("left out, not larger than twice their standard uncertainty (k = 2): " +
              (left_out.empty() ? std::string("none") : left_out));
  if (!undetermined.empty())
    h.push_back("left out, not determined by these runs (size or uncertainty beyond their circular deviation G): " +
                undetermined);
  if (!contradicted.empty()) h.push_back("left out, contradicting EXPLAIN on the same runs: " + contradicted);
  std::string other;
  for (const auto& t : m.terms)
    if (t.use == Use::not_geometric) other += (other.empty() ? "" : ", ") + estimate_text(t);
  if (!other.empty()) h.push_back("servo and friction effects, in no table: " + other);
  for (const auto& n : m.notes) h.push_back(n);
  return h;
}

std::string letters_upper(const std::string& s) {
  std::string o = s;
  for (auto& c : o) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return o;
}

}  // namespace

std::vector<std::string> compensation_file_names() {
  std::vector<std::string> names{"x.comp", "y.comp", "z.comp", "linuxcnc.ini", "errors.csv", "straightness.csv"};
  for (std::size_t k = 0, n = names.size(); k < n; ++k) names.push_back(names[k] + std::string(do_not_load_suffix));
  return names;
}

std::vector<OutputFile> compensation_files(const ErrorMap& m, const std::string& source) {
  return compensation_files(std::vector<ErrorMap>{m}, source);
}

namespace {

// Each axis' map once, from the first plane that sees it, with its plane's terms.
std::vector<std::pair<const ErrorMap*, std::size_t>> axes_once(const std::vector<ErrorMap>& planes) {
  std::vector<std::pair<const ErrorMap*, std::size_t>> out;
  for (const auto& m : planes)
    for (std::size_t k = 0; k < m.axes.size(); ++k)
      if (std::none_of(out.begin(), out.end(),
                       [&](const auto& a) { return a.first->axes[a.second].axis == m.axes[k].axis; }))
        out.emplace_back(&m, k);
  return out;
}

// The squareness of each plane as errors.csv's metadata (one plane: squareness_significant, as before).
void squareness_meta(const std::vector<ErrorMap>& planes, std::vector<std::pair<std::string, std::string>>& meta) {
  for (const auto& m : planes) {
    if (!m.squareness_known) continue;
    const std::string a = m.axes[0].axis, b = m.axes[1].axis;
    const auto adv = squareness_advice(m.squareness_rad);
    meta.emplace_back("squareness_" + a + b + "_urad", printf_number("%.3f", m.squareness_rad * 1e6));
    meta.emplace_back("squareness_" + a + b + "_u_urad", printf_number("%.3f", m.squareness_u_rad * 1e6));
    meta.emplace_back(
        planes.size() == 1 ? std::string("squareness_significant") : "squareness_" + a + b + "_significant",
        m.squareness_significant ? "true" : "false");
    meta.emplace_back("squareness_correction_" + a + "_um_per_100mm_" + b,
                      printf_number("%.3f", adv.correction_um_per_100mm));
  }
}

}  // namespace

std::vector<OutputFile> compensation_files(const std::vector<ErrorMap>& planes, const std::string& source) {
  if (planes.empty()) throw CompensationError("no plane to write compensation files of");
  std::vector<OutputFile> out;
  std::vector<std::string> head;
  std::string plane_names, table_names;
  for (const auto& m : planes) {
    plane_names += (plane_names.empty() ? "" : ",") + m.plane;
    for (const auto& l : header_lines(m, source))
      if (std::find(head.begin(), head.end(), l) == head.end()) head.push_back(l);
  }
  const auto axes = axes_once(planes);
  std::vector<formats::IniJoint> joints;
  for (const auto& [mp, k] : axes) {
    const ErrorMap& m = *mp;
    const AxisMap& am = m.axes[k];
    std::vector<formats::CompTriplet> table;
    for (std::size_t i = 0; i < am.nominal_m.size(); ++i)
      table.push_back({am.nominal_m[i] * 1e3, (am.nominal_m[i] + am.table_forward_m[i]) * 1e3,
                       (am.nominal_m[i] + am.table_reverse_m[i]) * 1e3});
    std::vector<std::string> c;
    c.push_back("LinuxCNC compensation table of joint " + std::to_string(joint_of(am.axis)) + " (axis " +
                letters_upper(am.axis) + "), COMP_FILE_TYPE = 0: nominal, actual moving +, actual moving - (mm)");
    c.push_back(
        "these comments follow the table because LinuxCNC stops reading at the first line that is not three numbers");
    c.insert(c.end(), head.begin(), head.end());
    c.push_back("in this table: scale, backlash and cyclic error of " + letters_upper(am.axis) +
                " (those applied above); straightness: straightness.csv (cross-axis), squareness: axis skew; both "
                "also in errors.csv");
    const auto& at = m.terms_of[k];
    if (at.cyclic_amplitude_m != 0.0) {
      if (at.cyclic_table_gain > 0)
        c.push_back("the cyclic part is multiplied by " + printf_number("%.4f", at.cyclic_table_gain) +
                    " = 1 / sinc^2(step / period): LinuxCNC's linear interpolation between lines " +
                    printf_number("%.3g", m.step_m * 1e3) + " mm apart attenuates a " +
                    printf_number("%.3g", at.cyclic_period_m * 1e3) +
                    " mm period by the inverse (errors.csv holds the error itself)");
      else
        c.push_back(
            "the cyclic error is NOT in this table: its period is shorter than two table steps (use a smaller "
            "circle or a finer --step-mm)");
    }
    out.push_back({am.axis + ".comp", formats::format_linuxcnc_comp(table, c)});
    joints.push_back({joint_of(am.axis), am.axis, am.axis + ".comp"});
    table_names += (table_names.empty() ? "" : " / ") + am.axis + ".comp";
  }
  std::vector<std::string> ic{"Guideway compensation: lines for the [JOINT_n] sections of the machine's INI file",
                              "copy " + table_names +
                                  " next to the INI file (COMP_FILE is read relative to it), "
                                  "then restart LinuxCNC",
                              "joint numbers assume trivial kinematics (X = 0, Y = 1, Z = 2): check your [KINS]"};
  for (const auto& l : head) ic.push_back(l);
  out.push_back({"linuxcnc.ini", formats::format_linuxcnc_ini(joints, ic)});

  std::vector<formats::ErrorMapRow> rows;
  for (const auto& [mp, k] : axes) {
    const AxisMap& am = mp->axes[k];
    for (std::size_t i = 0; i < am.nominal_m.size(); ++i)
      rows.push_back({am.axis, am.nominal_m[i] * 1e3, am.forward_m[i] * 1e6, am.reverse_m[i] * 1e6, am.across,
                      am.straightness_m[i] * 1e6});
  }
  std::vector<std::pair<std::string, std::string>> meta;
  meta.emplace_back("source", source);
  meta.emplace_back("plane", plane_names);
  meta.emplace_back("model", planes.front().model);
  squareness_meta(planes, meta);
  std::vector<std::string> ec = head;
  ec.push_back("forward_um / reverse_um: positioning error (actual - nominal) of the axis moving in + / -");
  ec.push_back("straightness_um: displacement of the axis along straightness_axis (ends relative to the centre)");
  for (const auto& m : planes) {
    const std::string a = m.axes[0].axis, b = m.axes[1].axis;
    ec.push_back("squareness (sign): actual " + a + " = " + a + " + q " + b + ", i.e. " + letters_upper(b) +
                 " leans towards +" + a + " for q > 0; um/m = urad");
  }
  if (planes.size() > 1)
    ec.push_back(
        "each axis once, from the first plane that sees it (its straightness along that plane's other axis; "
        "the other plane's in straightness.csv)");
  out.push_back({"errors.csv", formats::format_error_map_csv(rows, meta, ec)});

  // The cross-axis correction undoes the straightness: the other axis is commanded back by as much.
  std::vector<formats::CrossCorrectionRow> cross;
  for (const auto& m : planes)
    for (const auto& am : m.axes)
      if (am.straightness_applied)
        for (std::size_t i = 0; i < am.nominal_m.size(); ++i)
          cross.push_back({am.axis, am.nominal_m[i] * 1e3, am.across, -am.straightness_m[i] * 1e3});
  if (!cross.empty()) {
    std::vector<std::string> sc = head;
    sc.push_back(
        "correction_mm: added to the command of corrected_axis, interpolated linearly in moving_axis' "
        "commanded position (minus the straightness of moving_axis along corrected_axis; ends relative "
        "to the centre)");
    sc.push_back(
        "load it as a cross-axis / straightness compensation table (docs/compensation.md); a per-joint "
        "table cannot hold it");
    for (const auto& m : planes)
      for (const auto& am : m.axes)
        if (!am.straightness_applied)
          sc.push_back("no rows for " + am.axis + (planes.size() > 1 ? " along " + am.across : std::string()) +
                       ": its straightness is not larger than twice its uncertainty");
    out.push_back({"straightness.csv",
                   formats::format_straightness_csv(cross, {{"source", source}, {"plane", plane_names}}, sc)});
  }
  return out;
}

std::vector<RefusedFigure> use_machine_figures(std::vector<ErrorMap>& planes, const dbb::PlanesSummary& summary) {
  std::vector<RefusedFigure> refused;
  for (const auto* figures : {&summary.backlash, &summary.scale})
    for (const dbb::AxisFigure& f : *figures) {
      if (!f.consistent) refused.push_back({f.name, f.axis, f.note});
      std::string planes_text;
      for (const auto& p : f.from) planes_text += (planes_text.empty() ? "" : ", ") + p.plane;
      for (auto& m : planes)
        for (auto& t : m.terms) {
          if (t.name != f.name) continue;
          t.value = f.value;
          t.u = f.u;
          t.significant = std::abs(f.value) > 2 * f.u;
          if (!f.consistent) t.contradiction = "the planes disagree: " + f.note;
          if (f.from.size() > 1)
            m.notes.push_back(f.name + ": the planes' combined figure (" + planes_text + "), " +
                              with_uncertainty(f.value, f.u, 3) + ", in place of this plane's alone");
        }
    }
  for (auto& m : planes) {
    for (std::size_t k = 0; k < m.axes.size(); ++k) {
      AxisTerms& at = m.terms_of[k];
      at.scale = 0.0;
      at.backlash_m = 0.0;
      for (const auto& t : m.terms) {
        if (!t.applied()) continue;
        if (t.name == results::name(results::scale, m.plane, static_cast<int>(k))) at.scale = t.value * 1e-6;
        if (t.name == results::name(results::backlash, m.plane, static_cast<int>(k))) at.backlash_m = t.value * 1e-6;
      }
      m.axes[k] = AxisMap{};
      fill_axis_map(m, static_cast<int>(k), at.radius_m);
    }
  }
  return refused;
}

namespace {

// Why the squareness is not entered as skew.
std::string squareness_left_out(const ErrorMap& m) {
  const auto* t = find(m.terms, results::name(results::squareness));
  const std::string why = t ? left_out_because(*t) : "";
  return why.empty() || why == "left out (not larger than 2 u)" ? "not significant" : why;
}

}  // namespace

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

bool determined(const std::string& name, double value, double u, double g_um, double radius_m, double feed_m_per_s) {
  if (!(g_um > 0) || !std::isfinite(value) || !std::isfinite(u)) return std::isfinite(value);
  double um_per_unit = 0;  // the term's size on the circle per unit of it
  if (name.ends_with("_um"))
    um_per_unit = 1;
  else if (name.ends_with("_ppm") || name.ends_with("_urad"))
    um_per_unit = radius_m;  // 1e-6 of r (m), in um
  else if (name.ends_with("_ms"))
    um_per_unit = feed_m_per_s * 1e3;  // a lag of 1 ms at v (m/s): v 1e-3 m = v 1e3 um
  else
    return true;
  return !(std::abs(value) * um_per_unit > 10 * g_um) && !(u * um_per_unit > g_um);
}

}  // namespace guideway::models::compensation
