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

results::StraightnessLine line_record(const ReferenceLine& r) {
  results::StraightnessLine l;
  l.straightness_um = r.straightness_m * um;
  l.u_straightness_um = r.u_straightness_m * um;
  l.u_first_order_um = r.u_first_order_m * um;
  l.selection_bias_um = r.selection_bias_m * um;
  l.u_straightness_data_um = r.u_straightness_data_m * um;
  l.slope_urad = r.slope * urad;
  l.max_station = r.max_index;
  l.min_station = r.min_index;
  return l;
}

results::StraightnessPolynomial polynomial_record(const StraightnessProfile& p) {
  const auto& f = p.polynomial;
  results::StraightnessPolynomial poly;
  poly.criterion = "BIC on the chord-slope fit";
  poly.order = static_cast<std::size_t>(f.order);
  poly.at_cap = f.order == static_cast<int>(f.bic.size()) && f.order > 1;
  poly.x_origin_mm = p.x_m.front() * 1e3;
  // Eq. 10 in Mu's units: height in mm, x in mm (b_k mm^(1-k)), and in SI.
  for (std::size_t k = 0; k < f.b.size(); ++k) {
    const double scale = 1e3 / std::pow(1e3, static_cast<double>(k));
    poly.b_mm.push_back(f.b[k] * scale);
    poly.u_b_mm.push_back(f.u_b[k] * scale);
  }
  poly.bic = f.bic;
  poly.residual_rms_um = f.residual_rms_m * um;
  poly.residual_max_um = f.residual_max_m * um;
  poly.angle_residual_rms_arcsec = f.angle_residual_rms_rad / rad_per_arcsec;
  poly.condition_number = f.condition_number;
  return poly;
}

results::StraightnessPlane plane_record(const StraightnessProfile& p) {
  results::StraightnessPlane out;
  out.plane = p.plane;
  out.u_angle_arcsec = p.u_angle_rad / rad_per_arcsec;
  out.u_angle_data_arcsec = p.u_angle_data_rad / rad_per_arcsec;
  out.u_disagreement = p.u_disagreement;
  out.tilt_arcsec = p.tilt_rad / rad_per_arcsec;
  out.span_arcsec = p.span_rad / rad_per_arcsec;
  out.u_end_height_um = p.u_height_m.back() * um;
  out.end_point = line_record(p.end_point);
  out.least_squares = line_record(p.least_squares);
  out.minimum_zone = line_record(p.minimum_zone);
  out.polynomial = polynomial_record(p);
  const auto& f = p.polynomial;
  for (std::size_t k = 0; k < p.x_m.size(); ++k) {
    out.stations.push_back({p.x_m[k] * 1e3, p.height_m[k] * um, p.u_height_m[k] * um, p.end_point.deviation_m[k] * um,
                            p.end_point.u_deviation_m[k] * um, p.least_squares.deviation_m[k] * um,
                            p.least_squares.u_deviation_m[k] * um, f.residual_m[k] * um});
  }
  return out;
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

results::TraverseModelResult traverse_model_result(const StraightnessResult& r) {
  results::TraverseModelResult out;
  out.model = std::string(results::traverse_model);
  out.source = r.source;
  out.step_mm = r.step_m * 1e3;
  out.readings = r.readings;
  out.instrument = r.instrument.name;
  out.instrument_range_arcsec = r.instrument.range_rad / rad_per_arcsec;
  out.instrument_u_arcsec = r.instrument.reading_u_rad() / rad_per_arcsec;
  out.jitter_percent = 100 * r.jitter;
  out.jitter_tolerance_percent = 100 * station_jitter_tolerance;
  out.vertical = plane_record(r.vertical);
  if (r.horizontal) out.horizontal = plane_record(*r.horizontal);
  return out;
}

nlohmann::json to_json(const StraightnessResult& r) { return results::to_json(traverse_model_result(r)); }

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

results::RunoutModelResult runout_model_result(const RunoutResult& r) {
  results::RunoutModelResult out;
  out.model = std::string(results::runout_model);
  out.samples = r.samples;
  out.amplitude_um = r.amplitude_m * um;
  out.u_amplitude_um = r.u_amplitude_m * um;
  out.phase_deg = r.phase_rad * 180.0 / std::numbers::pi;
  out.u_phase_deg = r.u_phase_rad * 180.0 / std::numbers::pi;
  out.offset_um = r.offset_m * um;
  out.twice_per_rev_amplitude_um = r.second_harmonic_m * um;
  out.residual_rms_um = r.residual_rms_m * um;
  out.condition_number = r.condition_number;
  out.runout_um = r.runout_m * um;
  out.u_runout_um = r.u_runout_m * um;
  out.parallelism_um = r.parallelism_m * um;
  out.plate_diameter_mm = r.plate_diameter_m * 1e3;
  out.deflection_urad = r.deflection_rad * urad;
  out.u_deflection_urad = r.u_deflection_rad * urad;
  out.squareness_urad = out.deflection_urad;  // Eq. 21's deflection is the spindle's squareness
  out.u_squareness_urad = out.u_deflection_urad;
  if (r.travel_m) {
    out.travel_mm = *r.travel_m * 1e3;
    out.squareness_amplitude_um = *r.squareness_amplitude_m * um;
    out.u_squareness_amplitude_um = *r.u_squareness_amplitude_m * um;
  }
  return out;
}

nlohmann::json to_json(const RunoutResult& r) { return results::to_json(runout_model_result(r)); }

results::ErrorMotionRecord error_motion_record(const ErrorMotionResult& r) {
  results::ErrorMotionRecord out;
  out.model = std::string(results::error_motion_model);
  out.revolutions = r.revolutions;
  out.samples = r.samples;
  out.points_per_rev = r.points_per_rev;
  out.total_um = r.total_m * um;
  out.synchronous_um = r.synchronous_m * um;
  out.asynchronous_um = r.asynchronous_m * um;
  out.fundamental_um = r.fundamental_m * um;
  out.fundamental_phase_deg = r.fundamental_phase_rad * 180.0 / std::numbers::pi;
  return out;
}

nlohmann::json to_json(const ErrorMotionResult& r) { return results::to_json(error_motion_record(r)); }

results::RunoutModelResult runout_model_result(const RunoutRevolution& rev) {
  results::RunoutModelResult out = runout_model_result(identify_runout(rev));
  if (whole_revolutions(rev.angle_rad) >= 1)
    out.error_motion = error_motion_record(error_motion(rev.angle_rad, rev.runout_m, rev.source));
  return out;
}

nlohmann::json runout_json(const RunoutRevolution& rev) { return results::to_json(runout_model_result(rev)); }

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
