// A run-out's revolution and a profile's wavelet summary as JSON (kind_records.hpp), written and read: the one
// place their keys are spelled.
#include "results/kind_records.hpp"

#include <nlohmann/json.hpp>

#include "results/json_fields.hpp"
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

}  // namespace

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
