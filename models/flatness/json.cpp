// The flatness results as JSON (json.hpp): units in the key names, uncertainties as "u_<name>".
#include "models/flatness/json.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "models/flatness/instruments.hpp"
#include "results/parameters.hpp"

namespace guideway::models::flatness {

namespace {

constexpr double um = 1e6;
constexpr double urad = 1e6;
constexpr double tens_of_microinch_per_m = 1.0 / (0.0254 * 1e-5);

nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json line_json(const ReferenceLine& r) {
  return {{"straightness_um", r.straightness_m * um},
          {"u_straightness_um", r.u_straightness_m * um},
          {"u_first_order_um", r.u_first_order_m * um},
          {"selection_bias_um", r.selection_bias_m * um},
          {"u_straightness_data_um", finite_or_null(r.u_straightness_data_m * um)},
          {"slope_urad", r.slope * urad},
          {"max_station", r.max_index},
          {"min_station", r.min_index}};
}

nlohmann::json profile_json(const StraightnessProfile& p) {
  nlohmann::json j;
  j["plane"] = p.plane;
  j["u_angle_arcsec"] = p.u_angle_rad / rad_per_arcsec;
  j["u_angle_data_arcsec"] = finite_or_null(p.u_angle_data_rad / rad_per_arcsec);
  j["u_disagreement"] = p.u_disagreement.empty() ? nlohmann::json(nullptr) : nlohmann::json(p.u_disagreement);
  j["tilt_arcsec"] = p.tilt_rad / rad_per_arcsec;
  j["span_arcsec"] = p.span_rad / rad_per_arcsec;
  j["u_end_height_um"] = p.u_height_m.back() * um;
  j["end_point"] = line_json(p.end_point);
  j["least_squares"] = line_json(p.least_squares);
  j["minimum_zone"] = line_json(p.minimum_zone);
  const auto& f = p.polynomial;
  nlohmann::json poly;
  poly["criterion"] = "BIC on the chord-slope fit";
  poly["order"] = f.order;
  poly["at_cap"] = f.order == static_cast<int>(f.bic.size()) && f.order > 1;
  poly["x_origin_mm"] = p.x_m.front() * 1e3;
  // Eq. 10 in Mu's units: height in mm, x in mm (b_k mm^(1-k)), and in SI.
  nlohmann::json b_mm = nlohmann::json::array(), u_b_mm = nlohmann::json::array();
  for (std::size_t k = 0; k < f.b.size(); ++k) {
    const double scale = 1e3 / std::pow(1e3, static_cast<double>(k));
    b_mm.push_back(f.b[k] * scale);
    u_b_mm.push_back(f.u_b[k] * scale);
  }
  poly["b_mm"] = b_mm;
  poly["u_b_mm"] = u_b_mm;
  poly["bic"] = f.bic;
  poly["residual_rms_um"] = f.residual_rms_m * um;
  poly["residual_max_um"] = f.residual_max_m * um;
  poly["angle_residual_rms_arcsec"] = f.angle_residual_rms_rad / rad_per_arcsec;
  poly["condition_number"] = f.condition_number;
  j["polynomial"] = poly;
  nlohmann::json st = nlohmann::json::array();
  for (std::size_t k = 0; k < p.x_m.size(); ++k) {
    st.push_back({{"x_mm", p.x_m[k] * 1e3},
                  {"height_um", p.height_m[k] * um},
                  {"u_height_um", p.u_height_m[k] * um},
                  {"end_point_um", p.end_point.deviation_m[k] * um},
                  {"u_end_point_um", p.end_point.u_deviation_m[k] * um},
                  {"least_squares_um", p.least_squares.deviation_m[k] * um},
                  {"u_least_squares_um", p.least_squares.u_deviation_m[k] * um},
                  {"fit_residual_um", f.residual_m[k] * um}});
  }
  j["stations"] = st;
  return j;
}

nlohmann::json stations_json(const std::vector<UnionJackStation>& st, double s, bool inch,
                             const std::vector<double>* u = nullptr) {
  nlohmann::json a = nlohmann::json::array();
  for (std::size_t k = 0; k < st.size(); ++k) {
    nlohmann::json j = {{"x_steps", st[k].x_steps},
                        {"y_steps", st[k].y_steps},
                        {"x_mm", st[k].x_steps * s * 1e3},
                        {"y_mm", st[k].y_steps * s * 1e3},
                        {"height_um", st[k].height_m * um}};
    if (inch) j["height_10uin"] = st[k].height_m * tens_of_microinch_per_m;
    if (u) j["u_height_um"] = (*u)[k] * um;
    a.push_back(j);
  }
  return a;
}

}  // namespace

nlohmann::json to_json(const StraightnessResult& r) {
  nlohmann::json j;
  j["model"] = "straightness/autocollimator";
  j["source"] = r.source;
  j["step_mm"] = r.step_m * 1e3;
  j["readings"] = r.readings;
  j["instrument"] = {{"name", r.instrument.name},
                     {"range_arcsec", r.instrument.range_rad / rad_per_arcsec},
                     {"u_arcsec", r.instrument.reading_u_rad() / rad_per_arcsec}};
  j["jitter_percent"] = 100 * r.jitter;
  j["jitter_tolerance_percent"] = 100 * station_jitter_tolerance;
  j["vertical"] = profile_json(r.vertical);
  if (r.horizontal) j["horizontal"] = profile_json(*r.horizontal);
  return j;
}

nlohmann::json to_json(const UnionJackResult& r, bool inch) {
  nlohmann::json j;
  j["model"] = "flatness/union-jack";
  j["foot_spacing_mm"] = r.foot_spacing_m * 1e3;
  j["steps"] = {{"long", r.long_steps}, {"short", r.short_steps}, {"diagonal", r.diagonal_steps}};
  j["flatness_um"] = r.flatness_m * um;
  j["flatness_lsq_plane_um"] = r.flatness_lsq_plane_m * um;
  j["flatness_min_zone_um"] = r.flatness_min_zone_m * um;
  if (inch) j["flatness_10uin"] = r.flatness_m * tens_of_microinch_per_m;
  nlohmann::json closure;
  nlohmann::json lines = nlohmann::json::array();
  for (const auto& l : r.lines) {
    nlohmann::json lj = {{"name", l.name}, {"stations", stations_json(l.stations, r.foot_spacing_m, inch)}};
    if (l.closure_m) {
      lj["closure_um"] = *l.closure_m * um;
      closure[l.name + "_um"] = *l.closure_m * um;
      if (inch) closure[l.name + "_10uin"] = *l.closure_m * tens_of_microinch_per_m;
    }
    lines.push_back(lj);
  }
  j["closure"] = closure;
  j["lines"] = lines;
  if (!r.warnings.empty()) j["warnings"] = r.warnings;
  if (r.lsq) {
    const auto& l = *r.lsq;
    nlohmann::json offsets;
    for (std::size_t i = 0; i < 8; ++i) offsets[union_jack_names[i]] = l.offset_rad[i] / rad_per_arcsec;
    j["least_squares"] = {{"flatness_um", l.flatness_m * um},
                          {"flatness_min_zone_um", l.flatness_min_zone_m * um},
                          {"residual_rms_arcsec", l.residual_rms_rad / rad_per_arcsec},
                          {"readings", l.readings},
                          {"unknowns", l.unknowns},
                          {"redundancy", l.redundancy},
                          {"line_offset_arcsec", offsets},
                          {"stations", stations_json(l.stations, r.foot_spacing_m, inch, &l.u_height_m)}};
  }
  return j;
}

nlohmann::json to_json(const RunoutResult& r) {
  nlohmann::json j;
  j["model"] = "squareness/runout";
  j["samples"] = r.samples;
  j["once_per_rev"] = {{"amplitude_um", r.amplitude_m * um},
                       {"u_amplitude_um", r.u_amplitude_m * um},
                       {"phase_deg", r.phase_rad * 180.0 / std::numbers::pi},
                       {"u_phase_deg", r.u_phase_rad * 180.0 / std::numbers::pi}};
  j["offset_um"] = r.offset_m * um;
  j["twice_per_rev_amplitude_um"] = r.second_harmonic_m * um;
  j["residual_rms_um"] = r.residual_rms_m * um;
  j["condition_number"] = r.condition_number;
  // The headline figures' names from the catalogue (results/parameters.hpp), their u's "u_" before them.
  j[results::name(results::runout)] = r.runout_m * um;
  j["u_" + results::name(results::runout)] = r.u_runout_m * um;
  j["parallelism_um"] = r.parallelism_m * um;
  j["plate_diameter_mm"] = r.plate_diameter_m * 1e3;
  j["deflection_urad"] = r.deflection_rad * urad;
  j["u_deflection_urad"] = r.u_deflection_rad * urad;
  j[results::name(results::runout_squareness)] = r.deflection_rad * urad;
  j["u_" + results::name(results::runout_squareness)] = r.u_deflection_rad * urad;
  if (r.travel_m) {
    j["travel_mm"] = *r.travel_m * 1e3;
    j["squareness_amplitude_um"] = *r.squareness_amplitude_m * um;
    j["u_squareness_amplitude_um"] = *r.u_squareness_amplitude_m * um;
  }
  return j;
}

nlohmann::json to_json(const ErrorMotionResult& r) {
  nlohmann::json j;
  j["model"] = "error_motion/iso230-7";
  j["revolutions"] = r.revolutions;
  j["samples"] = r.samples;
  j["points_per_rev"] = r.points_per_rev;
  j[results::name(results::total_error_motion)] = r.total_m * um;
  j[results::name(results::synchronous_error_motion)] = r.synchronous_m * um;
  j[results::name(results::asynchronous_error_motion)] = r.asynchronous_m * um;
  j[results::name(results::fundamental_error_motion)] = r.fundamental_m * um;
  j["fundamental_phase_deg"] = r.fundamental_phase_rad * 180.0 / std::numbers::pi;
  return j;
}

nlohmann::json runout_json(const RunoutRevolution& rev) {
  nlohmann::json j = to_json(identify_runout(rev));
  if (whole_revolutions(rev.angle_rad) >= 1)
    j["error_motion"] = to_json(error_motion(rev.angle_rad, rev.runout_m, rev.source));
  return j;
}

nlohmann::json reversal_json(const RunoutRevolution& first, const RunoutRevolution& turned) {
  if (!turned.artifact_turned_rad)
    throw std::invalid_argument(turned.source + ": no artifact_turned_deg: how far the artifact was turned against " +
                                first.source + " is not stated");
  for (const RunoutRevolution* r : {&first, &turned}) {
    if (!r->angle_from_spindle_zero)
      throw std::invalid_argument(r->source +
                                  ": its angles count from its first reading (angle_zero = first_reading): a reversal "
                                  "needs both records' angles from the spindle's zero (an index or encoder)");
    if (whole_revolutions(r->angle_rad) < 1)
      throw std::invalid_argument(r->source + ": less than one whole revolution recorded");
  }
  const double turned_rad = *turned.artifact_turned_rad - first.artifact_turned_rad.value_or(0.0);
  const ReversalResult r = separate_reversal(
      error_motion(first.angle_rad, first.runout_m, first.source), first.angle_rad.front(),
      error_motion(turned.angle_rad, turned.runout_m, turned.source), turned.angle_rad.front(), turned_rad);
  nlohmann::json j;
  j["model"] = "error_motion/iso230-7 reversal (Donaldson)";
  j["records"] = {first.source, turned.source};
  j["turned_deg"] = turned_rad * 180.0 / std::numbers::pi;
  j["points_per_rev"] = r.points_per_rev;
  j[results::name(results::spindle_synchronous_error_motion)] = r.spindle_synchronous_m * um;
  j[results::name(results::artifact_form_error)] = r.artifact_form_m * um;
  j["together_orders"] = r.together_orders;
  return j;
}

}  // namespace guideway::models::flatness
