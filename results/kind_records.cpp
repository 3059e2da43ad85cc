// A run-out's revolution and model result, a profile's wavelet summary, points and number as JSON (kind_records.hpp),
// written and read: the one place their keys are spelled (the catalogue's figures under their catalogue names).
#include "results/kind_records.hpp"

#include <cstdint>
#include <utility>
#include <variant>

#include <nlohmann/json.hpp>

#include "results/json_fields.hpp"
#include "results/parameters.hpp"
#include "results/params.hpp"

namespace guideway::results {

namespace {

using nlohmann::json;
using namespace json_fields;

// The optional numbers of a band, each written only when it has one.
struct BandValue {
  const char* key;
  std::optional<double> WaveletBand::*value;
};
constexpr BandValue band_values[] = {{"form_um", &WaveletBand::form_um},
                                     {"rms_um", &WaveletBand::rms_um},
                                     {"noise_rms_um", &WaveletBand::noise_rms_um},
                                     {"signal_rms_um", &WaveletBand::signal_rms_um},
                                     {"wavelength_min_mm", &WaveletBand::wavelength_min_mm},
                                     {"wavelength_max_mm", &WaveletBand::wavelength_max_mm}};

json band_json(const WaveletBand& b) {
  json j = {{"band", b.band}, {"coefficients", b.coefficients}};
  for (const BandValue& v : band_values)
    if (b.*v.value) j[v.key] = *(b.*v.value);
  return j;
}

WaveletBand band_from(const json& o, const std::string& w) {
  WaveletBand b;
  read(o, w, "band", b.band);
  read(o, w, "coefficients", b.coefficients);
  for (const BandValue& v : band_values) read(o, w, v.key, b.*v.value);
  return b;
}

// The numbers of a run-out's result and its error motion under their keys (json_fields::NumberField), written and
// read from these lists; the figures the catalogue names are under their catalogue names.
constexpr NumberField<RunoutModelResult> once_per_rev_numbers[] = {
    {"amplitude_um", &RunoutModelResult::amplitude_um},
    {"u_amplitude_um", &RunoutModelResult::u_amplitude_um},
    {"phase_deg", &RunoutModelResult::phase_deg},
    {"u_phase_deg", &RunoutModelResult::u_phase_deg}};
constexpr NumberField<RunoutModelResult> runout_numbers[] = {
    {"offset_um", &RunoutModelResult::offset_um},
    {"twice_per_rev_amplitude_um", &RunoutModelResult::twice_per_rev_amplitude_um},
    {"residual_rms_um", &RunoutModelResult::residual_rms_um},
    {"condition_number", &RunoutModelResult::condition_number},
    {"parallelism_um", &RunoutModelResult::parallelism_um},
    {"plate_diameter_mm", &RunoutModelResult::plate_diameter_mm},
    {"deflection_urad", &RunoutModelResult::deflection_urad},
    {"u_deflection_urad", &RunoutModelResult::u_deflection_urad}};
constexpr std::pair<const char*, std::optional<double> RunoutModelResult::*> travel_numbers[] = {
    {"travel_mm", &RunoutModelResult::travel_mm},
    {"squareness_amplitude_um", &RunoutModelResult::squareness_amplitude_um},
    {"u_squareness_amplitude_um", &RunoutModelResult::u_squareness_amplitude_um}};

// A catalogue figure of a run-out's result, and its u ("u_" before its name).
struct CatalogueFigure {
  const Parameter* entry;
  double RunoutModelResult::*value;
  double RunoutModelResult::*u;
};
constexpr CatalogueFigure runout_figures[] = {
    {&runout, &RunoutModelResult::runout_um, &RunoutModelResult::u_runout_um},
    {&runout_squareness, &RunoutModelResult::squareness_urad, &RunoutModelResult::u_squareness_urad}};

// The error motion's figures, each under its catalogue name.
struct ErrorMotionFigure {
  const Parameter* entry;
  double ErrorMotionRecord::*value;
};
constexpr ErrorMotionFigure error_motion_figures[] = {{&total_error_motion, &ErrorMotionRecord::total_um},
                                                      {&synchronous_error_motion, &ErrorMotionRecord::synchronous_um},
                                                      {&asynchronous_error_motion, &ErrorMotionRecord::asynchronous_um},
                                                      {&fundamental_error_motion, &ErrorMotionRecord::fundamental_um}};

constexpr NumberField<ProfilePoints> points_numbers[] = {{"spacing_um", &ProfilePoints::spacing_um},
                                                         {"length_mm", &ProfilePoints::length_mm}};

ErrorMotionRecord error_motion_from(const json& o, const std::string& w) {
  ErrorMotionRecord e;
  read(o, w, "model", e.model);
  read(o, w, "revolutions", e.revolutions);
  read(o, w, "samples", e.samples);
  read(o, w, "points_per_rev", e.points_per_rev);
  for (const ErrorMotionFigure& f : error_motion_figures) read(o, w, name(*f.entry).c_str(), e.*f.value);
  read(o, w, "fundamental_phase_deg", e.fundamental_phase_deg);
  return e;
}

}  // namespace

json to_json(const ErrorMotionRecord& e) {
  json j = {{"model", e.model},
            {"revolutions", e.revolutions},
            {"samples", e.samples},
            {"points_per_rev", e.points_per_rev},
            {"fundamental_phase_deg", e.fundamental_phase_deg}};
  for (const ErrorMotionFigure& f : error_motion_figures) j[name(*f.entry)] = e.*f.value;
  return j;
}

json to_json(const RunoutModelResult& r) {
  json once = json::object();
  write_numbers(once, r, once_per_rev_numbers);
  json j = {{"model", r.model}, {"samples", r.samples}, {"once_per_rev", std::move(once)}};
  write_numbers(j, r, runout_numbers);
  for (const CatalogueFigure& f : runout_figures) {
    const std::string key = name(*f.entry);
    j[key] = r.*f.value;
    j["u_" + key] = r.*f.u;
  }
  for (const auto& [key, member] : travel_numbers)
    if (r.*member) j[key] = *(r.*member);
  if (r.error_motion) j["error_motion"] = to_json(*r.error_motion);
  return j;
}

json to_json(const ProfilePoints& p) {
  json j = {{"count", p.count}, {"invalid", p.invalid}};
  write_numbers(j, p, points_numbers);
  return j;
}

json profile_id_json(const ProfileId& id) {
  return std::visit([](auto v) { return json(v); }, id);
}

RunoutModelResult runout_result_from_json(const json& j) {
  return rethrown_as<ParamsFormatError>([&] {
    const std::string w(result_key);
    RunoutModelResult r;
    read(object_at(j, w), w, "model", r.model);
    read(j, w, "samples", r.samples);
    if (const json* v = object_field(j, w, "once_per_rev"))
      read_numbers(*v, at(w, "once_per_rev"), r, once_per_rev_numbers);
    read_numbers(j, w, r, runout_numbers);
    for (const CatalogueFigure& f : runout_figures) {
      const std::string key = name(*f.entry);
      read(j, w, key.c_str(), r.*f.value);
      read(j, w, ("u_" + key).c_str(), r.*f.u);
    }
    for (const auto& [key, member] : travel_numbers) read(j, w, key, r.*member);
    if (const json* v = object_field(j, w, "error_motion"))
      r.error_motion = error_motion_from(*v, at(w, "error_motion"));
    return r;
  });
}

ProfilePoints points_from_json(const json& j) {
  return rethrown_as<ParamsFormatError>([&] {
    const std::string w(points_key);
    ProfilePoints p;
    read(object_at(j, w), w, "count", p.count);
    read(j, w, "invalid", p.invalid);
    read_numbers(j, w, p, points_numbers);
    return p;
  });
}

ProfileId profile_id_from_json(const json& j) {
  if (is_count(j)) return j.get<std::uint64_t>();
  if (j.is_number()) return j.get<double>();
  throw ParamsFormatError("\"" + std::string(profile_id_key) + "\" is " + j.type_name() + ", expected a number");
}

std::string_view result_model(const json& result) {
  if (!result.is_object()) return {};
  const auto model = result.find("model");
  return model != result.end() && model->is_string() ? std::string_view(model->get_ref<const std::string&>())
                                                     : std::string_view();
}

json to_json(const RunoutRevolution& r) {
  json j = {{"samples", r.samples}, {"rpm", r.rpm}, {"covered_deg", r.covered_deg}};
  if (r.revolutions) j["revolutions"] = *r.revolutions;
  return j;
}

json to_json(const WaveletSummary& s) {
  json bands = json::array();
  for (const WaveletBand& b : s.bands) bands.push_back(band_json(b));
  return {{"wavelet", s.wavelet},
          {"mode", s.mode},
          {"level", s.level},
          {"bands", std::move(bands)},
          {"dominant_detail", s.dominant_detail}};
}

RunoutRevolution revolution_from_json(const json& j) {
  return rethrown_as<ParamsFormatError>([&] {
    const std::string w(revolution_key);
    RunoutRevolution r;
    read(object_at(j, w), w, "samples", r.samples);
    read(j, w, "rpm", r.rpm);
    read(j, w, "covered_deg", r.covered_deg);
    if (j.contains("revolutions")) read(j, w, "revolutions", r.revolutions.emplace());
    return r;
  });
}

WaveletSummary wavelet_from_json(const json& j) {
  return rethrown_as<ParamsFormatError>([&] {
    const std::string w(wavelet_key);
    WaveletSummary s;
    read(object_at(j, w), w, "wavelet", s.wavelet);
    read(j, w, "mode", s.mode);
    read(j, w, "level", s.level);
    read_objects(j, w, "bands", s.bands, band_from);
    read(j, w, "dominant_detail", s.dominant_detail);
    return s;
  });
}

}  // namespace guideway::results
