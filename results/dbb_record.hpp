#pragma once
// A DBB identification's record of how it fitted, as every layer above the models reads it: the part of a DBB
// PARAMS (docs/protocol.md "PARAMS") that is not figures: each run's set-up and G ("runs"), the errors' parts of G
// ("ranking", "ranking_model"), the fits ("fit", "diagnostics_fit"), the standards' figures with their test
// conditions ("standards"), the notes, and of a test of several planes the machine across them ("summary").
// models/dbb builds it (to_params), results::Params holds it (params.hpp), the CLI prints its fields. Its JSON is
// written by to_json and read by dbb_record_from_json only, so its keys are spelled in results/dbb_record.cpp and
// nowhere else (the standards' figures under their catalogue names, parameters.hpp). A number the JSON gives as
// null (not computed, not finite) is NaN here. Pure; thread safe.

#include <cstddef>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace guideway::results {

inline constexpr double record_nan = std::numeric_limits<double>::quiet_NaN();

// One run: its set-up, its circular deviation G and the diagnostics fit's residual on it.
struct DbbRunSummary {
  std::string source;
  double radius_mm = record_nan;
  double height_mm = record_nan;
  std::string direction;  // "ccw" | "cw"
  double feed_mm_per_min = record_nan;
  std::size_t n = 0;  // samples
  double circular_deviation_um = record_nan;
  double residual_rms_um = record_nan;
  std::optional<double> data_arc_deg;  // a partial arc's (absent: the full circle)
  std::size_t gaps = 0;                // dropouts inside it
  friend bool operator==(const DbbRunSummary&, const DbbRunSummary&) = default;
};

// A combination of terms the runs determine where they cannot separate its terms.
struct DbbCombination {
  std::string expression;  // "a1_rad + 320.256*c1_per_mm"
  double value = record_nan;
  double u = record_nan;
  friend bool operator==(const DbbCombination&, const DbbCombination&) = default;
};

// A fit in figures: how well it fits and what the runs cannot separate.
struct DbbFit {
  double rms_um = 0.0;
  std::size_t n = 0;  // points fitted (0: not fitted)
  double condition_number = 0.0;  // infinite: "inf" in the JSON
  std::vector<std::string> unidentifiable;
  std::vector<DbbCombination> combinations;
  std::string message;           // the solver's ("": none)
  std::vector<std::string> why;  // on partial arcs or gappy runs: why each unidentifiable term is
  friend bool operator==(const DbbFit&, const DbbFit&) = default;
};

// An error's part of the circular deviation G ("what to fix first").
struct DbbContribution {
  std::string plane;  // of the machine across its planes (its "ranking"); "" in one plane's own
  std::string name;   // as the ranking names it ("backlash_x", "y_straightness_in_z")
  double contribution_um = record_nan;
  double percent_of_circular_deviation = record_nan;  // NaN: null
  friend bool operator==(const DbbContribution&, const DbbContribution&) = default;
};

// A run's test conditions (ISO 230-4 asks them stated beside the figures); nullopt: "not recorded".
struct DbbTestConditions {
  double radius_mm = record_nan;
  double height_mm = record_nan;
  double feed_mm_per_min = record_nan;
  std::string direction;
  double data_arc_deg = 360.0;
  bool partial_arc = false;
  std::size_t samples = 0;
  double spacing_deg = record_nan;
  std::size_t gaps = 0;
  std::optional<double> feed_in_deg, feed_out_deg, temperature_c;
  friend bool operator==(const DbbTestConditions&, const DbbTestConditions&) = default;
};

// The standards' figures of a run (ISO 230-4, ASME B5.54; docs/standards.md), over its data arc.
struct DbbStandardRun {
  std::size_t run = 0;  // from 1
  std::string source;
  std::string over;  // "the full circle", "the 220 deg arc"
  DbbTestConditions conditions;
  double iso_circular_deviation_um = record_nan;
  double iso_radial_deviation_max_um = record_nan;
  double iso_radial_deviation_min_um = record_nan;
  double asme_circularity_um = record_nan;
  friend bool operator==(const DbbStandardRun&, const DbbStandardRun&) = default;
};

// ... and of a CCW/CW pair of one set-up.
struct DbbStandardPair {
  std::size_t ccw_run = 0, cw_run = 0;  // from 1
  double common_arc_deg = record_nan;
  std::string over;
  double iso_circular_hysteresis_um = record_nan;
  double iso_bidirectional_deviation_um = record_nan;
  double asme_hysteresis_um = record_nan;
  double asme_bidirectional_circularity_um = record_nan;
  friend bool operator==(const DbbStandardPair&, const DbbStandardPair&) = default;
};

struct DbbStandards {
  std::vector<DbbStandardRun> runs;
  std::vector<DbbStandardPair> pairs;
  friend bool operator==(const DbbStandards&, const DbbStandards&) = default;
};

// A value with its standard uncertainty, if any.
struct DbbEstimate {
  double value = record_nan;
  std::optional<double> u;
  friend bool operator==(const DbbEstimate&, const DbbEstimate&) = default;
};

// An axis' figure from every plane that sees it: their weighted mean, each plane's, and whether they agree.
struct DbbAxisFigure {
  std::string axis;
  DbbEstimate estimate;
  bool consistent = true;
  std::vector<std::pair<std::string, DbbEstimate>> from;  // plane, its value
  std::string note;
  friend bool operator==(const DbbAxisFigure&, const DbbAxisFigure&) = default;
};

// The machine across its test planes (models/dbb/three_planes), by the names the catalogue gives them there
// (parameters.hpp planes_group): "squareness_xz_urad", "backlash_z_um".
struct DbbPlanesSummary {
  std::vector<std::string> planes;  // in the order given
  std::map<std::string, DbbEstimate> squareness;
  std::map<std::string, DbbEstimate> scale_mismatch;
  std::map<std::string, DbbAxisFigure> backlash;
  std::map<std::string, DbbAxisFigure> scale;
  std::vector<DbbContribution> ranking;  // largest first
  double circular_deviation_um = record_nan;
  std::vector<std::string> notes;
  friend bool operator==(const DbbPlanesSummary&, const DbbPlanesSummary&) = default;
};

struct DbbRecord {
  std::vector<DbbRunSummary> runs;
  std::vector<DbbContribution> ranking;  // largest first
  std::string ranking_model;             // "diagnostics" or "lai3"
  std::vector<std::string> notes;
  DbbFit fit;              // Lai's third-order fit
  DbbFit diagnostics_fit;  // the ballbar diagnostics'
  DbbStandards standards;
  std::optional<DbbPlanesSummary> summary;  // several planes: the machine across them
  friend bool operator==(const DbbRecord&, const DbbRecord&) = default;
};

// Whether `key` is one of a DBB record's in a PARAMS.
[[nodiscard]] bool is_dbb_record_key(std::string_view key);

// The record's keys (merged into the PARAMS' body by to_json(Params)).
nlohmann::json to_json(const DbbRecord& record);
nlohmann::json to_json(const DbbPlanesSummary& summary);

// The record a PARAMS' body holds (its other keys are ignored); a key that is absent takes its default. Throws
// ParamsFormatError (params.hpp) naming the field for a key of the wrong type ("runs[1]: \"radius_mm\" is string,
// expected a number or null").
DbbRecord dbb_record_from_json(const nlohmann::json& j);

}  // namespace guideway::results
