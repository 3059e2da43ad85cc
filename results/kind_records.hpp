#pragma once
// The records of a run-out and a profile session besides their figures, as every layer above the models reads
// them (a DBB identification's is dbb_record.hpp, a traverse's traverse_record.hpp): a run-out's revolution
// (PARAMS' "revolution": what was recorded, which `explain --machine` compares with a machine file) and its model's
// result ("result": Mu's Eq. 21 and ISO 230-7's error motion, also `guideway identify runout --json`), a profile's
// wavelet summary ("wavelet": each band's rms, the dominant detail, which the CLI prints), its points ("points") and
// its number ("profile_id"). results::Params holds them (params.hpp); their JSON is written by to_json and read by
// the *_from_json below only, so their keys are spelled in results/kind_records.cpp and nowhere else. A number the
// JSON gives as null is NaN here. Pure; thread safe.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
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

// ISO 230-7's error motion of a run-out's whole revolutions, its peaks-to-valleys in um under their catalogue names
// (parameters.hpp: total, synchronous, asynchronous and fundamental error motion).
struct ErrorMotionRecord {
  std::string model;  // error_motion_model
  std::size_t revolutions = 0;
  std::size_t samples = 0;
  std::size_t points_per_rev = 0;
  double total_um = std::numeric_limits<double>::quiet_NaN();
  double synchronous_um = std::numeric_limits<double>::quiet_NaN();
  double asynchronous_um = std::numeric_limits<double>::quiet_NaN();
  double fundamental_um = std::numeric_limits<double>::quiet_NaN();  // the once-per-revolution term removed
  double fundamental_phase_deg = std::numeric_limits<double>::quiet_NaN();
};

// A run-out's model result: Mu's Eq. 21 fitted to the revolution (the once-per-revolution term, the run-out r = 2 A,
// the spindle's squareness from it) and, from one whole revolution on, the error motion.
struct RunoutModelResult {
  std::string model;  // runout_model
  std::size_t samples = 0;
  double amplitude_um = std::numeric_limits<double>::quiet_NaN();  // the once-per-revolution term ("once_per_rev")
  double u_amplitude_um = std::numeric_limits<double>::quiet_NaN();
  double phase_deg = std::numeric_limits<double>::quiet_NaN();
  double u_phase_deg = std::numeric_limits<double>::quiet_NaN();
  double offset_um = std::numeric_limits<double>::quiet_NaN();
  double twice_per_rev_amplitude_um = std::numeric_limits<double>::quiet_NaN();
  double residual_rms_um = std::numeric_limits<double>::quiet_NaN();
  double condition_number = std::numeric_limits<double>::quiet_NaN();
  double runout_um = std::numeric_limits<double>::quiet_NaN();  // under its catalogue name (results::runout)
  double u_runout_um = std::numeric_limits<double>::quiet_NaN();
  double parallelism_um = std::numeric_limits<double>::quiet_NaN();
  double plate_diameter_mm = std::numeric_limits<double>::quiet_NaN();
  double deflection_urad = std::numeric_limits<double>::quiet_NaN();  // Eq. 21's theta_0
  double u_deflection_urad = std::numeric_limits<double>::quiet_NaN();
  // The same deflection under its catalogue name (results::runout_squareness), as the JSON repeats it.
  double squareness_urad = std::numeric_limits<double>::quiet_NaN();
  double u_squareness_urad = std::numeric_limits<double>::quiet_NaN();
  std::optional<double> travel_mm, squareness_amplitude_um, u_squareness_amplitude_um;  // with a travel stated
  std::optional<ErrorMotionRecord> error_motion;                                        // from one whole revolution on
};

// A profile's points: how many, how many invalid, their spacing and the length they span.
struct ProfilePoints {
  std::size_t count = 0;
  std::size_t invalid = 0;
  double spacing_um = std::numeric_limits<double>::quiet_NaN();
  double length_mm = std::numeric_limits<double>::quiet_NaN();
};

// A profile session's profile number (the profilometer's `profile` channel): a whole number. Releases before
// 2026-11-21 wrote it as a number with a fraction ("29.0"): read, and written back, as such.
using ProfileId = std::variant<std::uint64_t, double>;

// The PARAMS keys these records are under, and the models that tell a run-out's result from a traverse's under
// PARAMS' one key "result" (traverse_record.hpp).
inline constexpr std::string_view revolution_key = "revolution";
inline constexpr std::string_view wavelet_key = "wavelet";
inline constexpr std::string_view result_key = "result";
inline constexpr std::string_view points_key = "points";
inline constexpr std::string_view profile_id_key = "profile_id";
inline constexpr std::string_view runout_model = "squareness/runout";
inline constexpr std::string_view error_motion_model = "error_motion/iso230-7";

nlohmann::json to_json(const RunoutRevolution& revolution);
nlohmann::json to_json(const WaveletSummary& wavelet);
nlohmann::json to_json(const ErrorMotionRecord& error_motion);
nlohmann::json to_json(const RunoutModelResult& result);
nlohmann::json to_json(const ProfilePoints& points);
nlohmann::json profile_id_json(const ProfileId& id);  // not a to_json: a bare number converts to it

// The record a JSON object holds; a key that is absent takes its default. Throws ParamsFormatError (params.hpp)
// naming the field for a key of the wrong type ("revolution: \"rpm\" is string, expected a number or null").
RunoutRevolution revolution_from_json(const nlohmann::json& j);
WaveletSummary wavelet_from_json(const nlohmann::json& j);
RunoutModelResult runout_result_from_json(const nlohmann::json& j);
ProfilePoints points_from_json(const nlohmann::json& j);
ProfileId profile_id_from_json(const nlohmann::json& j);

// The model a result object names ("" when it names none): which of the records above (or traverse_record.hpp's)
// PARAMS' "result" holds.
[[nodiscard]] std::string_view result_model(const nlohmann::json& result);

}  // namespace guideway::results
