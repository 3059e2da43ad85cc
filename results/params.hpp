#pragma once
// PARAMS as every layer above the models reads it: the body of a PARAMS message (docs/protocol.md "PARAMS"),
// what a session's identify() returns, the daemon and `guideway replay` publish and the fleet stores. Its
// figures, every {"value": v, "u": u} a result reports, are typed: each under its reported name with its
// catalogue entry (parameters.hpp), in the group the message holds it in ("diagnostics", "lai3", "squareness",
// "error_motion", "straightness", "profile", ...), so a reader asks for a quantity, not for a key path. Its JSON
// is written by to_json and read by params_from_json only. A figure's value the JSON gives as null (not
// computed, not finite) is NaN here. Pure; thread safe.
//
// The model's own record of how it fitted, typed: `dbb`, a DBB identification's (dbb_record.hpp: its runs, fits,
// standards' figures, ranking and notes, and of a test of several planes the machine across them), a run-out's
// revolution and model result, a profile's wavelet bands, points and number (kind_records.hpp), a traverse's set-up
// and model result (traverse_record.hpp), and of a test of several planes each plane's PARAMS (`planes`). What
// none of them holds stays in `record`, key by key as it came: a session kind results/ does not type (a test's), a
// newer release's keys from a broker or a file. No session kind of this release writes one.

#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "results/dbb_record.hpp"
#include "results/kind_records.hpp"
#include "results/parameters.hpp"
#include "results/traverse_record.hpp"

namespace guideway::results {

inline constexpr double params_nan = std::numeric_limits<double>::quiet_NaN();

// One reported value: {"value": v, "u": u} (u left out where there is none; "not_determined": why, where an
// identified term contradicts EXPLAIN's value of it: models/explain/dbb_checked.hpp).
struct Figure {
  std::string name;                  // as reported: "backlash_x_um", "run2.center_offset_x_um"
  double value = params_nan;         // NaN: null in the JSON
  std::optional<double> u;           // standard uncertainty; absent: none given (NaN: null in the JSON)
  std::string not_determined;        // why the term is not determined ("": it is)
  const Parameter* entry = nullptr;  // its catalogue entry (find_parameter with the group); nullptr: not in it
};

// A group of figures, {"name": {"value": ...}, ...}: its name is a catalogue group (Parameter::group).
struct FigureGroup {
  std::string name;
  std::vector<Figure> figures;
  [[nodiscard]] const Figure* find(std::string_view figure_name) const;
};

struct Params;

// One plane's identification in a test of several planes (PARAMS' "planes"): its PARAMS, or why it has none.
struct PlaneParams {
  std::shared_ptr<const Params> params;  // nullptr: not identified
  std::string error;                     // why not ("": it was)
};

struct Params {
  std::string model;       // "dbb/lai3+diagnostics", "squareness/runout", ...
  std::string plane;       // a DBB identification's plane ("xy", "zx"); "" for the other kinds
  std::string axis;        // a traverse's machine axis ("x"); ""
  std::string test;        // a DBB session's test ("standard", "three-plane"); ""
  std::string incomplete;  // what a session stopped early lacks ("3 of 4 patterns traced"); "": complete
  std::vector<FigureGroup> groups;
  std::optional<DbbRecord> dbb;                        // a DBB identification's record (above)
  std::optional<RunoutRevolution> revolution;          // a run-out's
  std::optional<RunoutModelResult> runout_result;      // a run-out's model result ("result")
  std::optional<TraverseSetup> traverse;               // a traverse's set-up
  std::optional<TraverseModelResult> traverse_result;  // a traverse's model result ("result")
  std::optional<WaveletSummary> wavelet;               // a profile's
  std::optional<ProfilePoints> points;                 // a profile's
  std::optional<ProfileId> profile_id;                 // a profile session's
  std::map<std::string, PlaneParams> planes;           // a test of several planes: each plane's (the first's is this)
  nlohmann::json record = nlohmann::json::object();    // what none of the above holds (above), an object

  [[nodiscard]] const FigureGroup* group(std::string_view name) const;
  // The figure `name` of group `group`; nullptr when either is absent.
  [[nodiscard]] const Figure* find(std::string_view group, std::string_view name) const;
  // The group `name`, added (empty) when absent.
  FigureGroup& group_named(std::string_view name);
};

// The figure `name` of group `group` with its catalogue entry (find_parameter(name, group)).
Figure figure(std::string name, double value, std::optional<double> u, std::string_view group);

// The PARAMS message's body without its header (result_header.hpp).
nlohmann::json to_json(const Params& params);
// PARAMS' "planes": each plane's PARAMS, or {"error": why} for a plane not identified.
nlohmann::json planes_json(const std::map<std::string, PlaneParams>& planes);

// What params_from_json refuses: names the field and what it is ("diagnostics.backlash_x_um: \"value\" is string,
// expected a number or null").
class ParamsFormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// The PARAMS a JSON object holds (a PARAMS message: its header is left out). A key whose value is an object of
// figures (each an object of "value", and "u" or "not_determined" only) is a group; "model", "plane", "axis",
// "test" and "incomplete" must be texts; a DBB record's keys (is_dbb_record_key) are read into `dbb`
// (dbb_record_from_json), "revolution", "traverse", "wavelet", "points" and "profile_id" into theirs, "result" into
// the run-out's or the traverse's model result by the model it names (result_model), "planes" (each an object:
// "error", or a plane's PARAMS, itself without planes) into `planes`; every other key is the record's. A figure
// whose value or u is not a number (or null), a record's key of the wrong type, or a non-object, throws
// ParamsFormatError: what comes from a broker or a file goes through here, a bad payload is an error, never
// undefined behaviour.
Params params_from_json(const nlohmann::json& j);

}  // namespace guideway::results
