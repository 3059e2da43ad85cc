// The catalogue of reported parameters (parameters.hpp): names with their units, where a result holds them, how they
// are shown.
#include "results/parameters.hpp"

#include "core/number_format.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <vector>

namespace guideway::results {

namespace {

constexpr const Parameter* all[] = {
    &circular_deviation,
    &circular_hysteresis,
    &iso_circular_deviation,
    &iso_radial_deviation_max,
    &iso_radial_deviation_min,
    &asme_circularity,
    &iso_circular_hysteresis,
    &iso_bidirectional_deviation,
    &asme_hysteresis,
    &asme_bidirectional_circularity,
    &center_offset,
    &squareness,
    &backlash,
    &scale,
    &scale_mismatch,
    &lateral_play,
    &servo_mismatch,
    &straightness_bow,
    &reversal_spike,
    &reversal_spike_decay,
    &reversal_spike_delay,
    &cyclic_sin,
    &cyclic_cos,
    &cyclic_error,
    &cyclic_period,
    &cyclic_phase,
    // Lai
    &lai_e_x,
    &lai_e_y,
    &lai_S_x,
    &lai_S_y,
    &lai_a1,
    &lai_a2,
    &lai_a3,
    &lai_b2,
    &lai_b3,
    &lai_c0_plus_d1,
    &lai_c1,
    &lai_c2,
    &lai_d2,
    &lai_d3,
    &lai_e1,
    &lai_e2,
    &lai_e3,
    &lai_mismatch_phase_angle,
    // the ranking of Lai's terms
    &rank_straightness_ab,
    &rank_straightness_ba,
    &rank_straightness_an,
    &rank_straightness_bn,
    &rank_roll_b,
    &rank_roll_b_straightness_an,
    // compensation
    &straightness_cubic,
    &straightness_cubic_difference,
    // EXPLAIN, DBB
    &backlash_delay,
    &spike_decay,
    &compensation_step,
    &compensation_step_lag,
    &cyclic_sin_column,
    &cyclic_cos_column,
    &cyclic_delay,
    &bar_drift,
    &bar_drift_offset,
    &centre_drift,
    &centre_drift_offset,
    &vibration_sin,
    &vibration_cos,
    &beside_vibration,  // before vibration, whose {axis} would take "amplitude"
    &beside_vibration_phase,
    &vibration,
    &vibration_phase,
    &vibration_frequency,
    &stick_slip,
    &stick_slip_frequency,
    &stick_slip_decay,
    &servo_lag,
    &sensor_quadratic,
    &sensor_cubic,
    // EXPLAIN, profiles
    &abbe_offset,
    &profile_drift,
    &runout_sin,
    &runout_cos,
    &runout_per_rev,
    &spindle_axial_runout,
    &spindle_axial_runout_phase,
    &tool_wear,
    &nose_curvature,
    &nose_curvature_quadrature,
    &feed_marks,
    &tool_nose_radius,
    &profile_cyclic_sin,
    &profile_cyclic_cos,
    // headlines of the other kinds
    &runout_squareness,
    &runout,
    &total_error_motion,
    &synchronous_error_motion,
    &asynchronous_error_motion,
    &fundamental_error_motion,
    &spindle_synchronous_error_motion,
    &artifact_form_error,
    &runout_order_sin,
    &runout_order_cos,
    &runout_order,
    &synchronous_harmonic,
    &synchronous_harmonic_phase,
    &asynchronous_line,
    &asynchronous_line_phase,
    &axial_growth,
    &speed_offset,
    &speed_ramp,
    &artifact_form,
    &artifact_form_phase,
    &speed_ripple,
    &speed_ripple_phase,
    &angle_drift,
    &reflector_rocking,
    &pitch_wave_sin,
    &pitch_wave_cos,
    &pitch_wave,
    &pitch_wave_phase,
    &pitch_wave_period,
    &yaw_coupling,
    &horizontal_straightness,
    &vertical_straightness,
    &profile_straightness,
    &form_straightness,
};

// Unit suffixes, the longer of two that end alike first ("_per_mm2" before "_per_mm", "_um" before "_m").
struct Unit {
  std::string_view suffix;
  std::string_view symbol;
};
constexpr Unit units[] = {{"_um_per_min", "\u00b5m/min"},
                          {"_arcsec_per_min", "\u2033/min"},
                          {"_percent_per_min", "%/min"},
                          {"_percent", "%"},
                          {"_per_rev", "/rev"},
                          {"_um_per_m", "\u00b5m/m"},
                          {"_per_um2", "1/\u00b5m\u00b2"},
                          {"_per_um", "1/\u00b5m"},
                          {"_per_mm2", "1/mm\u00b2"},
                          {"_per_mm", "1/mm"},
                          {"_um", "\u00b5m"},
                          {"_ppm", "ppm"},
                          {"_urad", "\u00b5rad"},
                          {"_ms", "ms"},
                          {"_mm", "mm"},
                          {"_deg", "deg"},
                          {"_rad", "rad"},
                          {"_s", "s"},
                          {"_arcsec", "\u2033"},
                          {"_nm", "nm"},
                          {"_m", "m"},
                          {"_hz", "Hz"}};

void replace_all(std::string& text, std::string_view key, std::string_view by) {
  for (auto at = text.find(key); at != std::string::npos; at = text.find(key, at + by.size()))
    text.replace(at, key.size(), by);
}

std::string upper(std::string text) {
  for (char& c : text)
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
  return text;
}

// The plane's normal: the axis of x, y, z that is not one of its two.
std::string normal_letter(std::string_view plane) {
  const std::string a = axis_letter(plane, 0), b = axis_letter(plane, 1);
  for (const char* n : {"z", "y", "x"})
    if (a != n && b != n) return n;
  return "z";
}

std::string filled(std::string_view pattern, std::string_view plane, std::string_view along, int run) {
  std::string out(pattern);
  replace_all(out, "{a}", axis_letter(plane, 0));
  replace_all(out, "{b}", axis_letter(plane, 1));
  replace_all(out, "{A}", upper(axis_letter(plane, 0)));
  replace_all(out, "{B}", upper(axis_letter(plane, 1)));
  replace_all(out, "{N}", upper(normal_letter(plane)));
  if (!along.empty()) replace_all(out, "{axis}", along);
  if (run > 0) replace_all(out, "{run}", std::to_string(run));
  return out;
}

// Whether `name` is `pattern` with its placeholders filled: {axis} a word of letters, {a} and {b} one
// letter, {lai} x or y, {run} a number. `filled_by`, when given, receives what {axis}, {lai} and {run} stood for.
struct Placeholders {
  std::string axis;
  std::string lai;
  int run = 0;
};
bool matches(std::string_view pattern, std::string_view name, Placeholders* filled_by = nullptr) {
  if (pattern.empty()) return name.empty();
  if (pattern.front() == '{') {
    const auto close = pattern.find('}');
    const std::string_view key = pattern.substr(1, close - 1);
    const std::string_view rest = pattern.substr(close + 1);
    const auto fits = [&](char c) {
      if (key == "run") return c >= '0' && c <= '9';
      if (key == "lai") return c == 'x' || c == 'y';
      return c >= 'a' && c <= 'z';
    };
    const std::size_t most = key == "a" || key == "b" || key == "lai" ? 1 : name.size();
    for (std::size_t n = 1; n <= most && n <= name.size() && fits(name[n - 1]); ++n)
      if (matches(rest, name.substr(n), filled_by)) {
        if (filled_by && key == "axis") filled_by->axis = std::string(name.substr(0, n));
        if (filled_by && key == "lai") filled_by->lai = std::string(name.substr(0, n));
        if (filled_by && key == "run") filled_by->run = std::stoi(std::string(name.substr(0, n)));
        return true;
      }
    return false;
  }
  return !name.empty() && name.front() == pattern.front() && matches(pattern.substr(1), name.substr(1), filled_by);
}

// "run2.name" and "name_run2" -> "name": a name of one run among several; `run` receives its number.
std::string_view without_run(std::string_view name, int* run = nullptr) {
  const auto digits = [](std::string_view d) {
    return !d.empty() && d.size() < 6 && d.find_first_not_of("0123456789") == std::string_view::npos;
  };
  if (name.starts_with("run")) {
    const auto dot = name.find('.');
    if (dot != std::string_view::npos && digits(name.substr(3, dot - 3))) {
      if (run) *run = std::stoi(std::string(name.substr(3, dot - 3)));
      return name.substr(dot + 1);
    }
  }
  const auto at = name.rfind("_run");
  if (at != std::string_view::npos && digits(name.substr(at + 4))) {
    if (run) *run = std::stoi(std::string(name.substr(at + 4)));
    return name.substr(0, at);
  }
  return name;
}

// The entry `name` is an instance of, by its own name or a place's, the one named so in `group` first; the place
// (nullptr: its own name) and what its placeholders stood for.
struct Found {
  const Parameter* p = nullptr;
  const Place* place = nullptr;
  Placeholders by;
};
Found find_in(std::string_view name, std::string_view group) {
  Found first;
  std::string_view first_group;
  for (const Parameter* p : all) {
    for (std::size_t k = 0; k <= p->places.size(); ++k) {
      const Place* place = k == 0 ? nullptr : &p->places[k - 1];
      const std::string_view in = place ? place->group : p->group;
      Placeholders here;
      if (!matches(place ? place->name : p->name, name, &here)) continue;
      if (!first.p || (!group.empty() && in == group && first_group != group)) {
        first = {p, place, std::move(here)};
        first_group = in;
      }
      if (group.empty() || first_group == group) return first;
    }
  }
  return first;
}

}  // namespace

std::span<const Parameter* const> catalogue() { return all; }

std::optional<LineNames> line_of_part(std::string_view part_name) {
  struct Line {  // references: catalogue() above is where each entry's address is taken (once)
    const Parameter &sine, &cosine, &amplitude, &phase;
  };
  static constexpr Line lines[] = {{vibration_sin, vibration_cos, beside_vibration, beside_vibration_phase},
                                   {cyclic_sin_column, cyclic_cos_column, cyclic_error, cyclic_phase}};
  int run = 0;
  const std::string_view bare = without_run(part_name, &run);
  for (const Line& line : lines)
    for (const Parameter* part : {&line.sine, &line.cosine}) {
      Placeholders by;
      if (!matches(part->name, bare, &by)) continue;
      const auto named = [&](const Parameter& p) {
        const std::string n = filled(p.name, "xy", by.axis, 0);
        return run > 0 ? run_suffixed(n, run) : n;
      };
      return LineNames{named(line.sine), named(line.cosine), named(line.amplitude), named(line.phase)};
    }
  return std::nullopt;
}

namespace {

// find_in, and without a run's prefix where the name as given is no entry's.
Found find_in_any_run(std::string_view name, std::string_view group) {
  Found f = find_in(name, group);
  return f.p ? f : find_in(without_run(name), group);
}

}  // namespace

const Parameter* find_parameter(std::string_view name, std::string_view group) {
  return find_in_any_run(name, group).p;
}

double shown_order(std::string_view name, std::string_view group) {
  const Found f = find_in_any_run(name, group);
  if (!f.p) return static_cast<double>(std::size(all));
  if (f.place && !f.place->shown_after.empty() && f.place->shown_after != name)
    return shown_order(f.place->shown_after, group) + 0.5;
  return static_cast<double>(std::find(std::begin(all), std::end(all), f.p) - std::begin(all));
}

std::string axis_letter(std::string_view plane, int axis) {
  if (plane.size() == 2) return std::string(1, plane[axis == 0 ? 0 : 1]);
  return axis == 0 ? "x" : "y";
}

std::string name(const Parameter& p, std::string_view plane, int axis) {
  return filled(p.name, plane, axis < 0 ? std::string() : axis_letter(plane, axis), 0);
}

std::string name_along(const Parameter& p, std::string_view along, int run) { return filled(p.name, "xy", along, run); }

std::string name_in(const Parameter& p, std::string_view group, std::string_view plane, int axis) {
  if (group == p.group) return name(p, plane, axis);
  for (const Place& place : p.places) {
    if (place.group != group) continue;
    std::string out = filled(place.name, plane, axis < 0 ? std::string() : axis_letter(plane, axis), 0);
    if (axis >= 0) replace_all(out, "{lai}", axis == 0 ? "x" : "y");
    return out;
  }
  return {};
}

// A label names an axis as machine tools do, by its capital ("backlash Z"); "bar" stays a word.
std::string axis_in_label(const std::string& along) { return along.size() == 1 ? upper(along) : along; }

std::string label(const Parameter& p, std::string_view plane, int axis) {
  return filled(p.label, plane, axis < 0 ? std::string() : axis_in_label(axis_letter(plane, axis)), 0);
}

bool per_axis(const Parameter& p) { return p.name.find("{axis}") != std::string_view::npos; }

std::string run_prefixed(int run, const std::string& name) { return "run" + std::to_string(run) + "." + name; }

std::string run_suffixed(const std::string& name, int run) { return name + "_run" + std::to_string(run); }

std::pair<std::string, std::string> split_unit(const std::string& name) {
  for (const auto& [suffix, symbol] : units)
    if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
      return {name.substr(0, name.size() - suffix.size()), std::string(symbol)};
  return {name, ""};
}

std::string unit(const Parameter& p) { return split_unit(std::string(p.name)).second; }

std::string in_words(std::string_view id) {
  std::string out(id);
  std::replace(out.begin(), out.end(), '_', ' ');
  return out;
}

std::string label_of(std::string_view name, std::string_view plane, std::string_view group) {
  int run = 0;
  const std::string_view bare = without_run(name, &run);
  Found f = find_in(name, group);
  if (f.p)
    run = 0;  // its {run} is in the name itself
  else if (bare != name)
    f = find_in(bare, group);
  std::string out;
  if (f.p) {
    // Lai's x and y are the plane's first and second axes: the label names which axes they are.
    const std::string along = f.by.lai.empty() ? f.by.axis : axis_letter(plane, f.by.lai == "x" ? 0 : 1);
    const std::string_view text = f.place && !f.place->label.empty() ? f.place->label : f.p->label;
    out = filled(text, plane, axis_in_label(along), f.by.run);
  } else {
    out = in_words(split_unit(std::string(bare)).first);
  }
  if (run > 0) out += " (run " + std::to_string(run) + ")";
  return out;
}

ShownUnit shown_unit(std::string_view name, std::string_view group) {
  const Parameter* p = find_parameter(name, group);
  if (p && !p->shown_as.unit.empty()) return {std::string(p->shown_as.unit), p->shown_as.factor, p->shown_as.offset};
  return {split_unit(std::string(without_run(name))).second, 1.0, 0.0};
}

Shown shown(std::string_view name, double value, double u, std::string_view plane, std::string_view group,
            int significant) {
  const ShownUnit su = shown_unit(name, group);
  return {
      label_of(name, plane, group),
      with_uncertainty((value - su.offset) * su.factor, std::isfinite(u) ? u * std::abs(su.factor) : u, significant),
      su.symbol};
}

std::span<const Parameter* const> headline_parameters(std::string_view kind) {
  static const std::map<std::string_view, std::vector<const Parameter*>, std::less<>> by_kind = [] {
    std::map<std::string_view, std::vector<const Parameter*>, std::less<>> m;
    for (const Parameter* p : all)
      if (p->headline > 0) m[p->kind].push_back(p);
    for (auto& [k, list] : m)
      std::stable_sort(list.begin(), list.end(),
                       [](const Parameter* a, const Parameter* b) { return a->headline < b->headline; });
    return m;
  }();
  const auto it = by_kind.find(kind);
  if (it == by_kind.end()) return {};
  return it->second;
}

}  // namespace guideway::results
