// A traverse's set-up and model result as JSON (traverse_record.hpp), written and read: the one place their keys are
// spelled.
#include "results/traverse_record.hpp"

#include <iterator>

#include <nlohmann/json.hpp>

#include "results/json_fields.hpp"
#include "results/params.hpp"

namespace guideway::results {

namespace {

using nlohmann::json;
using namespace json_fields;

// The numbers of each struct under their keys (json_fields::NumberField): written and read from these lists. The
// ones that may be unknown (the readings' own scatter) are written as null when not finite, beside them.
constexpr NumberField<TraverseSetup> setup_numbers[] = {{"step_mm", &TraverseSetup::step_mm},
                                                        {"start_mm", &TraverseSetup::start_mm}};
constexpr NumberField<StraightnessLine> line_numbers[] = {{"straightness_um", &StraightnessLine::straightness_um},
                                                          {"u_straightness_um", &StraightnessLine::u_straightness_um},
                                                          {"u_first_order_um", &StraightnessLine::u_first_order_um},
                                                          {"selection_bias_um", &StraightnessLine::selection_bias_um},
                                                          {"slope_urad", &StraightnessLine::slope_urad}};
constexpr NumberField<StraightnessPolynomial> polynomial_numbers[] = {
    {"x_origin_mm", &StraightnessPolynomial::x_origin_mm},
    {"residual_rms_um", &StraightnessPolynomial::residual_rms_um},
    {"residual_max_um", &StraightnessPolynomial::residual_max_um},
    {"angle_residual_rms_arcsec", &StraightnessPolynomial::angle_residual_rms_arcsec},
    {"condition_number", &StraightnessPolynomial::condition_number}};
constexpr NumberField<StraightnessStation> station_numbers[] = {
    {"x_mm", &StraightnessStation::x_mm},
    {"height_um", &StraightnessStation::height_um},
    {"u_height_um", &StraightnessStation::u_height_um},
    {"end_point_um", &StraightnessStation::end_point_um},
    {"u_end_point_um", &StraightnessStation::u_end_point_um},
    {"least_squares_um", &StraightnessStation::least_squares_um},
    {"u_least_squares_um", &StraightnessStation::u_least_squares_um},
    {"fit_residual_um", &StraightnessStation::fit_residual_um}};
constexpr NumberField<StraightnessPlane> plane_numbers[] = {{"u_angle_arcsec", &StraightnessPlane::u_angle_arcsec},
                                                            {"tilt_arcsec", &StraightnessPlane::tilt_arcsec},
                                                            {"span_arcsec", &StraightnessPlane::span_arcsec},
                                                            {"u_end_height_um", &StraightnessPlane::u_end_height_um}};
constexpr NumberField<TraverseModelResult> result_numbers[] = {
    {"step_mm", &TraverseModelResult::step_mm},
    {"jitter_percent", &TraverseModelResult::jitter_percent},
    {"jitter_tolerance_percent", &TraverseModelResult::jitter_tolerance_percent}};
constexpr NumberField<TraverseModelResult> instrument_numbers[] = {
    {"range_arcsec", &TraverseModelResult::instrument_range_arcsec},
    {"u_arcsec", &TraverseModelResult::instrument_u_arcsec}};

constexpr const char* reference_lines[] = {"end_point", "least_squares", "minimum_zone"};
constexpr StraightnessLine StraightnessPlane::*line_members[] = {
    &StraightnessPlane::end_point, &StraightnessPlane::least_squares, &StraightnessPlane::minimum_zone};

// ---- writing ---------------------------------------------------------------------------------------------

json line_json(const StraightnessLine& l) {
  json j = {{"u_straightness_data_um", finite_or_null(l.u_straightness_data_um)},
            {"max_station", l.max_station},
            {"min_station", l.min_station}};
  write_numbers(j, l, line_numbers);
  return j;
}

json polynomial_json(const StraightnessPolynomial& p) {
  json j = {{"criterion", p.criterion}, {"order", p.order},   {"at_cap", p.at_cap},
            {"b_mm", p.b_mm},           {"u_b_mm", p.u_b_mm}, {"bic", p.bic}};
  write_numbers(j, p, polynomial_numbers);
  return j;
}

json plane_json(const StraightnessPlane& p) {
  json j = {{"plane", p.plane},
            {"u_angle_data_arcsec", finite_or_null(p.u_angle_data_arcsec)},
            {"u_disagreement", p.u_disagreement.empty() ? json(nullptr) : json(p.u_disagreement)},
            {"polynomial", polynomial_json(p.polynomial)}};
  write_numbers(j, p, plane_numbers);
  for (std::size_t k = 0; k < std::size(reference_lines); ++k) j[reference_lines[k]] = line_json(p.*line_members[k]);
  json stations = json::array();
  for (const StraightnessStation& s : p.stations) {
    json e = json::object();
    write_numbers(e, s, station_numbers);
    stations.push_back(std::move(e));
  }
  j["stations"] = std::move(stations);
  return j;
}

// ---- reading: every key optional, every present one of its type (json_fields.hpp) --------------------------

StraightnessLine line_from(const json& o, const std::string& w) {
  StraightnessLine l;
  read_numbers(o, w, l, line_numbers);
  read(o, w, "u_straightness_data_um", l.u_straightness_data_um);
  read(o, w, "max_station", l.max_station);
  read(o, w, "min_station", l.min_station);
  return l;
}

StraightnessPolynomial polynomial_from(const json& o, const std::string& w) {
  StraightnessPolynomial p;
  read(o, w, "criterion", p.criterion);
  read(o, w, "order", p.order);
  read(o, w, "at_cap", p.at_cap);
  read(o, w, "b_mm", p.b_mm);
  read(o, w, "u_b_mm", p.u_b_mm);
  read(o, w, "bic", p.bic);
  read_numbers(o, w, p, polynomial_numbers);
  return p;
}

StraightnessStation station_from(const json& o, const std::string& w) {
  StraightnessStation s;
  read_numbers(o, w, s, station_numbers);
  return s;
}

StraightnessPlane plane_from(const json& o, const std::string& w) {
  StraightnessPlane p;
  read(o, w, "plane", p.plane);
  read_numbers(o, w, p, plane_numbers);
  read(o, w, "u_angle_data_arcsec", p.u_angle_data_arcsec);
  if (const json* v =
          field(o, w, "u_disagreement", "a text or null", [](const json& e) { return e.is_string() || e.is_null(); }))
    p.u_disagreement = v->is_null() ? std::string() : v->get<std::string>();
  for (std::size_t k = 0; k < std::size(reference_lines); ++k)
    if (const json* v = object_field(o, w, reference_lines[k]))
      p.*line_members[k] = line_from(*v, at(w, reference_lines[k]));
  if (const json* v = object_field(o, w, "polynomial")) p.polynomial = polynomial_from(*v, at(w, "polynomial"));
  read_objects(o, w, "stations", p.stations, station_from);
  return p;
}

}  // namespace

json to_json(const TraverseSetup& s) {
  json j = {{"stations", s.stations}, {"passes", s.passes}, {"axis", s.axis}};
  write_numbers(j, s, setup_numbers);
  return j;
}

json to_json(const TraverseModelResult& r) {
  json j = {{"model", r.model},
            {"readings", r.readings},
            {"instrument", {{"name", r.instrument}}},
            {"vertical", plane_json(r.vertical)}};
  if (r.source) j["source"] = *r.source;
  write_numbers(j, r, result_numbers);
  write_numbers(j["instrument"], r, instrument_numbers);
  if (r.horizontal) j["horizontal"] = plane_json(*r.horizontal);
  return j;
}

TraverseSetup traverse_setup_from_json(const json& j) {
  return rethrown_as<ParamsFormatError>([&] {
    const std::string w(traverse_key);
    TraverseSetup s;
    read(object_at(j, w), w, "stations", s.stations);
    read(j, w, "passes", s.passes);
    read(j, w, "axis", s.axis);
    read_numbers(j, w, s, setup_numbers);
    return s;
  });
}

TraverseModelResult traverse_result_from_json(const json& j) {
  return rethrown_as<ParamsFormatError>([&] {
    const std::string w = "result";
    TraverseModelResult r;
    read(object_at(j, w), w, "model", r.model);
    if (j.contains("source")) read(j, w, "source", r.source.emplace());
    read(j, w, "readings", r.readings);
    read_numbers(j, w, r, result_numbers);
    if (const json* v = object_field(j, w, "instrument")) {
      read(*v, at(w, "instrument"), "name", r.instrument);
      read_numbers(*v, at(w, "instrument"), r, instrument_numbers);
    }
    if (const json* v = object_field(j, w, "vertical")) r.vertical = plane_from(*v, at(w, "vertical"));
    if (const json* v = object_field(j, w, "horizontal")) r.horizontal = plane_from(*v, at(w, "horizontal"));
    return r;
  });
}

}  // namespace guideway::results
