#pragma once
// A straightness traverse's record besides its figures, as every layer above the models reads it: how the session
// measured ("traverse": stations, passes, step, start, axis) and the model's result ("result": each plane's
// reference lines with their uncertainties, Mu's polynomial, the stations), in the units its keys name.
// models/flatness builds the result (traverse_model_result), the straightness session both, results::Params holds
// them (params.hpp). Their JSON is written by to_json and read by the *_from_json below only, so their keys are
// spelled in results/traverse_record.cpp and nowhere else. A number the JSON gives as null is NaN here. Pure;
// thread safe.

#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace guideway::results {

// How a traverse session measured.
struct TraverseSetup {
  std::size_t stations = 0;  // readings of the first pass
  std::size_t passes = 0;
  double step_mm = std::numeric_limits<double>::quiet_NaN();
  double start_mm = std::numeric_limits<double>::quiet_NaN();
  std::string axis;  // the machine axis ("x")
};

// One reference line (ISO 230-1: end point, least squares, minimum zone): the straightness and its uncertainty's
// parts, the line's slope and the stations at the extremes.
struct StraightnessLine {
  double straightness_um = std::numeric_limits<double>::quiet_NaN();
  double u_straightness_um = std::numeric_limits<double>::quiet_NaN();
  double u_first_order_um = std::numeric_limits<double>::quiet_NaN();
  double selection_bias_um = std::numeric_limits<double>::quiet_NaN();
  double u_straightness_data_um = std::numeric_limits<double>::quiet_NaN();  // NaN: the scatter is not known
  double slope_urad = std::numeric_limits<double>::quiet_NaN();
  std::size_t max_station = 0;
  std::size_t min_station = 0;
};

// Mu's Eq. 10 fitted through the chord slopes, its order by BIC.
struct StraightnessPolynomial {
  std::string criterion;  // how the order was chosen
  std::size_t order = 0;
  bool at_cap = false;  // the highest order tried
  double x_origin_mm = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> b_mm, u_b_mm;  // b_k in mm^(1-k), x from the origin
  std::vector<double> bic;           // of the orders tried, from 1
  double residual_rms_um = std::numeric_limits<double>::quiet_NaN();
  double residual_max_um = std::numeric_limits<double>::quiet_NaN();
  double angle_residual_rms_arcsec = std::numeric_limits<double>::quiet_NaN();
  double condition_number = std::numeric_limits<double>::quiet_NaN();
};

// One station: its height, its deviations from the end-point and least-squares lines, and the polynomial's
// residual there.
struct StraightnessStation {
  double x_mm = std::numeric_limits<double>::quiet_NaN();
  double height_um = std::numeric_limits<double>::quiet_NaN();
  double u_height_um = std::numeric_limits<double>::quiet_NaN();
  double end_point_um = std::numeric_limits<double>::quiet_NaN();
  double u_end_point_um = std::numeric_limits<double>::quiet_NaN();
  double least_squares_um = std::numeric_limits<double>::quiet_NaN();
  double u_least_squares_um = std::numeric_limits<double>::quiet_NaN();
  double fit_residual_um = std::numeric_limits<double>::quiet_NaN();
};

// One plane of a traverse (vertical from pitch, horizontal from yaw).
struct StraightnessPlane {
  std::string plane;                                                      // "vertical" | "horizontal"
  double u_angle_arcsec = std::numeric_limits<double>::quiet_NaN();       // the instrument's, per reading
  double u_angle_data_arcsec = std::numeric_limits<double>::quiet_NaN();  // the readings' own scatter; NaN: unknown
  std::string u_disagreement;  // why the two differ ("": they agree; null in the JSON)
  double tilt_arcsec = std::numeric_limits<double>::quiet_NaN();
  double span_arcsec = std::numeric_limits<double>::quiet_NaN();
  double u_end_height_um = std::numeric_limits<double>::quiet_NaN();
  StraightnessLine end_point, least_squares, minimum_zone;
  StraightnessPolynomial polynomial;
  std::vector<StraightnessStation> stations;
};

// The model's result of a traverse (`guideway identify straightness --json`, PARAMS' "result" of a traverse).
struct TraverseModelResult {
  std::string model;                  // traverse_model
  std::optional<std::string> source;  // the file identified; a session's result names none
  double step_mm = std::numeric_limits<double>::quiet_NaN();
  std::size_t readings = 0;
  std::string instrument;  // its name ("autocollimator"), its range and its u per reading
  double instrument_range_arcsec = std::numeric_limits<double>::quiet_NaN();
  double instrument_u_arcsec = std::numeric_limits<double>::quiet_NaN();
  double jitter_percent = std::numeric_limits<double>::quiet_NaN();
  double jitter_tolerance_percent = std::numeric_limits<double>::quiet_NaN();
  StraightnessPlane vertical;
  std::optional<StraightnessPlane> horizontal;  // with yaw readings
};

// The model a traverse's result names: what tells it from a run-out's result under PARAMS' one key "result".
inline constexpr std::string_view traverse_model = "straightness/autocollimator";
inline constexpr std::string_view traverse_key = "traverse";

nlohmann::json to_json(const TraverseSetup& setup);
nlohmann::json to_json(const TraverseModelResult& result);

// The record a JSON object holds; a key that is absent takes its default. Throws ParamsFormatError (params.hpp)
// naming the field for a key of the wrong type ("result.vertical.polynomial: \"order\" is string, expected a whole
// number, 0 or more").
TraverseSetup traverse_setup_from_json(const nlohmann::json& j);
TraverseModelResult traverse_result_from_json(const nlohmann::json& j);

}  // namespace guideway::results
