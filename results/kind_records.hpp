#pragma once
// The records of a run-out and a profile session besides their figures, as every layer above the models reads
// them (a DBB identification's is dbb_record.hpp): a run-out's revolution (PARAMS' "revolution": what was
// recorded, which `explain --machine` compares with a machine file) and a profile's wavelet summary ("wavelet":
// each band's rms, the dominant detail, which the CLI prints). results::Params holds them (params.hpp); their
// JSON is written by to_json and read by the *_from_json below only, so their keys are spelled in
// results/kind_records.cpp and nowhere else. A number the JSON gives as null is NaN here. Pure; thread safe.

#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace guideway::results {

// What a run-out session recorded: its samples, the spindle speed, the angle covered, and the whole revolutions
// the ISO 230-7 error motion used (absent: less than one).
struct RunoutRevolution {
  std::size_t samples = 0;
  double rpm = std::numeric_limits<double>::quiet_NaN();
  double covered_deg = std::numeric_limits<double>::quiet_NaN();
  std::optional<std::size_t> revolutions;
  friend bool operator==(const RunoutRevolution&, const RunoutRevolution&) = default;
};

// One band of a profile's wavelet decomposition: the approximation ("a5": its form) or a detail ("d3": its rms,
// the part white noise of the profile's level explains, and the rest, its signal), with the wavelengths it holds.
// A value absent from the JSON is nullopt (the approximation has no rms, a detail no form).
struct WaveletBand {
  std::string band;
  std::size_t coefficients = 0;
  std::optional<double> form_um, rms_um, noise_rms_um, signal_rms_um, wavelength_min_mm, wavelength_max_mm;
  friend bool operator==(const WaveletBand&, const WaveletBand&) = default;
};

struct WaveletSummary {
  std::string wavelet;  // "db1"
  std::string mode;     // "symmetric"
  std::size_t level = 0;
  std::vector<WaveletBand> bands;  // the approximation, then the details from the coarsest
  std::string dominant_detail;     // the detail band with the most signal
  friend bool operator==(const WaveletSummary&, const WaveletSummary&) = default;
};

// The PARAMS keys these records are under.
inline constexpr std::string_view revolution_key = "revolution";
inline constexpr std::string_view wavelet_key = "wavelet";

nlohmann::json to_json(const RunoutRevolution& revolution);
nlohmann::json to_json(const WaveletSummary& wavelet);

// The record a JSON object holds; a key that is absent takes its default. Throws ParamsFormatError (params.hpp)
// naming the field for a key of the wrong type ("revolution: \"rpm\" is string, expected a number or null").
RunoutRevolution revolution_from_json(const nlohmann::json& j);
WaveletSummary wavelet_from_json(const nlohmann::json& j);

}  // namespace guideway::results
