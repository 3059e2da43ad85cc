// The compensation's error map of a DBB identification (compensation.hpp: error_map and what it checks): the
// terms checked and used, the plane axes' errors on the table's grid.
#include "models/compensation/compensation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "core/number_format.hpp"
#include "formats/compensation_files.hpp"
#include "models/compensation/compensation_common.hpp"
#include "models/explain/dbb_explain.hpp"
#include "results/parameters.hpp"

namespace guideway::models::compensation {

namespace {

using detail::find;
using detail::significance_k;

constexpr double pi = std::numbers::pi;

const dbb::Estimate* find(const dbb::Identification& id, const std::string& name) { return find(id.diagnostics, name); }

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
  if (!find(id.lai3, results::name(results::lai_S_x)) &&
      !find(id.lai3, results::name_in(results::backlash, results::lai3_group, "xy", 0))) {
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
