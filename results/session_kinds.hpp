#pragma once
// What each test-session kind is, as data: its name, what it measures, the options of its start request
// (type, default, range, help) and its headline figures (parameters.hpp). The sessions read their options
// through these entries (sessions/), the daemon and the CLI list them, the fleet and the report take the
// kinds and their order from here. Adding a kind: its entry here, its session in sessions/ (docs/
// architecture.md "Where a new thing goes"). Pure; thread safe.

#include <span>
#include <string>
#include <string_view>

#include "results/parameters.hpp"

namespace guideway::results {

enum class OptionType {
  number,   // any number in [min, max]
  integer,  // a whole number in [min, max]
  text,     // a string; `choices` ("a|b") when only some are allowed
  json,     // a JSON value the session checks itself (dbb's patterns)
};

struct SessionOption {
  std::string_view name;  // as in the start request's "options"
  OptionType type = OptionType::number;
  double fallback = 0.0;  // number, integer: the value when it is not given
  double min = 0.0;
  double max = 0.0;
  std::string_view fallback_text = {};  // text: the value when it is not given; json: how the default reads
  std::string_view choices = {};        // text: the allowed values, "|" between them ("" = any)
  std::string_view help = {};           // one line: what it sets (and its unit when the name has none)
};

// dbb: a DBB circular test. `test` picks a template (sessions/dbb_session.cpp); `patterns` replaces it.
inline constexpr SessionOption dbb_test{"test",
                                        OptionType::text,
                                        0,
                                        0,
                                        0,
                                        "standard",
                                        "standard|three-plane|lai",
                                        "standard: cw + ccw at h = 0 in the plane; three-plane: xy 360 deg, xz and yz "
                                        "220 deg, cw + ccw each; lai: Lai's three patterns"};
inline constexpr SessionOption dbb_feed_mm_per_min{"feed_mm_per_min",
                                                   OptionType::number,
                                                   1000.0,
                                                   0.0,
                                                   1e5,
                                                   {},
                                                   {},
                                                   "the feed of the circles (one 10 % off is not the test's; 0 = any)"};
inline constexpr SessionOption dbb_radius_mm{
    "radius_mm", OptionType::number, 100.0, 1.0, 2000.0, {}, {}, "the circles' radius (standard, three-plane)"};
inline constexpr SessionOption dbb_patterns{
    "patterns", OptionType::json,
    0,          0,
    0,          "the test's",
    {},         "the circles instead of a test, [{radius_mm, height_mm, direction, plane, data_arc_deg}]"};
inline constexpr SessionOption dbb_radius_tolerance_mm{"radius_tolerance_mm",
                                                       OptionType::number,
                                                       1.0,
                                                       0.001,
                                                       50.0,
                                                       {},
                                                       {},
                                                       "how far the bar may read from a pattern's radius"};
inline constexpr SessionOption dbb_min_speed_mm_per_min{
    "min_speed_mm_per_min", OptionType::number, 30.0, 0.1, 1e5, {}, {}, "slower counts as standing still"};
inline constexpr SessionOption dbb_plane{
    "plane", OptionType::text, 0, 0, 0, "xy", "xy|xz|yz", "the plane of the standard and lai tests' circles"};

// straightness: an autocollimator traverse.
// The default step: 600 mm in 32 steps, so that each pass of the emulated traverse has the 32 readings
// EXPLAIN's structure tests need (models/explain/traverse_explain.cpp).
inline constexpr SessionOption straightness_step_mm{"step_mm", OptionType::number,         18.75, 0.1, 10000.0, {},
                                                    {},        "distance between stations"};
inline constexpr SessionOption straightness_start_mm{
    "start_mm", OptionType::number, 0.0, -1e5, 1e5, {}, {}, "position of the first station"};
inline constexpr SessionOption straightness_stations{
    "stations", OptionType::integer, 0, 0, 100000, {}, {}, "stations per pass (0 = until the return)"};
inline constexpr SessionOption straightness_passes{
    "passes", OptionType::integer, 2, 1, 100, {}, {}, "passes: forward, back, forward... over the same stations"};
inline constexpr SessionOption straightness_start{"start",
                                                  OptionType::text,
                                                  0,
                                                  0,
                                                  0,
                                                  "return",
                                                  "return|now",
                                                  "start at the reflector's return to the first station, or now"};
inline constexpr SessionOption straightness_return_gap_s{
    "return_gap_s", OptionType::number, 1.0, 0.05, 600.0, {}, {}, "a gap in the readings this long marks the return"};
inline constexpr SessionOption straightness_min_dwell_s{
    "min_dwell_s", OptionType::number, 0.3, 0.0, 600.0, {}, {}, "shortest stay that counts as a station"};
inline constexpr SessionOption straightness_max_hole_s{
    "max_hole_s", OptionType::number, 0.45, 0.01, 600.0, {}, {}, "longest gap in the readings within a station"};
inline constexpr SessionOption straightness_settle_arcsec{"settle_arcsec",
                                                          OptionType::number,
                                                          0.5,
                                                          0.001,
                                                          1000.0,
                                                          {},
                                                          {},
                                                          "angle change below which the reflector is at rest"};
inline constexpr SessionOption straightness_pitch_channel{
    "pitch_channel", OptionType::text, 0, 0, 0, "angle_y", {}, "the device channel that reads the pitch"};
inline constexpr SessionOption straightness_yaw_channel{
    "yaw_channel", OptionType::text, 0, 0, 0, "angle_x", {}, "the device channel that reads the yaw (\"\" = none)"};
inline constexpr SessionOption straightness_axis{
    "axis",      OptionType::text, 0, 0, 0, "x", "x|y|z",
    "the carriage traversed: its pitch and yaw axes and the sign of each channel (docs/conventions.md)"};
inline constexpr SessionOption straightness_pitch_sign{
    "pitch_sign", OptionType::number, 0.0, -1.0, 1.0, {}, {},
    "1 or -1: the sign of the pitch reading (0: the axis' convention, X -1, Y and Z +1)"};
inline constexpr SessionOption straightness_yaw_sign{
    "yaw_sign", OptionType::number, 0.0, -1.0, 1.0, {}, {},
    "1 or -1: the sign of the yaw reading (0: the axis' convention, X +1, Y and Z -1)"};
inline constexpr SessionOption straightness_angle_u_arcsec{"angle_u_arcsec",
                                                           OptionType::number,
                                                           0.0,
                                                           0.0,
                                                           100.0,
                                                           {},
                                                           {},
                                                           "standard uncertainty of an angle (0 = the instrument's)"};
inline constexpr SessionOption straightness_max_order{
    "max_order", OptionType::integer, 8, 1, 8, {}, {}, "highest order of the straightness polynomial"};

// runout: a spindle revolution on a thrust plate.
inline constexpr SessionOption runout_plate_diameter_mm{
    "plate_diameter_mm", OptionType::number, 1000.0, 1.0, 1e5, {}, {}, "diameter the micrometer runs on"};
inline constexpr SessionOption runout_parallelism_um{
    "parallelism_um", OptionType::number, 2.5, -1e4, 1e4, {}, {}, "the plate's parallelism (Mu's Eq. 21)"};
inline constexpr SessionOption runout_parallelism_u_um{
    "parallelism_u_um", OptionType::number, 0.0, 0.0, 1e4, {}, {}, "its standard uncertainty"};
inline constexpr SessionOption runout_travel_mm{
    "travel_mm", OptionType::number, 600.0, 0.0, 1e5, {}, {}, "travel the squareness is given over"};
inline constexpr SessionOption runout_rpm{"rpm", OptionType::number, 60.0, 0.01, 1e5, {}, {}, "spindle speed (1/min)"};
// Several revolutions: ISO 230-7's synchronous (average) and asynchronous (spread) error motions.
inline constexpr SessionOption runout_revolutions{"revolutions",
                                                  OptionType::number,
                                                  20.0,
                                                  1.0,
                                                  1000.0,
                                                  {},
                                                  {},
                                                  "revolutions to record (ISO 230-7 error motion: several)"};
inline constexpr SessionOption runout_channel{
    "channel", OptionType::text, 0, 0, 0, "displacement", {}, "the device channel that reads the run-out"};
// Donaldson's reversal: the record states how far the artifact was turned against the record it is compared with.
inline constexpr SessionOption runout_artifact_turned_deg{
    "artifact_turned_deg",
    OptionType::number,
    0.0,
    -360.0,
    360.0,
    {},
    {},
    "the artifact's turn on the spindle since the record it is compared with (180: a reversal), in the file's header"};

// profile: one profilometer traverse.
inline constexpr SessionOption profile_wavelet{
    "wavelet", OptionType::text, 0, 0, 0, "db1", {}, "wavelet of the decomposition (dsp: db1..db20, sym2.., coif1..)"};
inline constexpr SessionOption profile_mode{
    "mode", OptionType::text, 0, 0, 0, "symmetric", {}, "signal extension at the ends (PyWavelets' names)"};
inline constexpr SessionOption profile_level{"level", OptionType::integer, 5, 1, 20, {}, {}, "decomposition levels"};
inline constexpr SessionOption profile_feed_mm_per_min{"feed_mm_per_min",
                                                       OptionType::number,
                                                       0.0,
                                                       0.0,
                                                       1e6,
                                                       {},
                                                       {},
                                                       "the cut's feed (0 = not given; with spindle_rpm: EXPLAIN)"};
inline constexpr SessionOption profile_spindle_rpm{
    "spindle_rpm", OptionType::number, 0.0, 0.0, 1e6, {}, {}, "the cut's spindle speed (0 = not given)"};

struct SessionKindInfo {
  std::string_view name;                          // "dbb": the start request's "kind", the recording's, the fleet's
  std::string_view summary;                       // what it measures, one line
  std::span<const SessionOption* const> options;  // in the order the kind lists them
};

inline constexpr const SessionOption* dbb_options[] = {
    &dbb_test,     &dbb_feed_mm_per_min,     &dbb_radius_mm,           &dbb_plane,
    &dbb_patterns, &dbb_radius_tolerance_mm, &dbb_min_speed_mm_per_min};
inline constexpr SessionKindInfo dbb_kind{
    "dbb", "DBB circular test: the circles of a double ball bar, Lai's third-order model and the ballbar diagnostics",
    dbb_options};

inline constexpr const SessionOption* runout_options[] = {
    &runout_plate_diameter_mm, &runout_parallelism_um, &runout_parallelism_u_um,   &runout_travel_mm, &runout_rpm,
    &runout_revolutions,       &runout_channel,        &runout_artifact_turned_deg};
inline constexpr SessionKindInfo runout_kind{
    "runout", "spindle run-out revolution on a thrust plate: squareness by Mu's Eq. 21", runout_options};

inline constexpr const SessionOption* straightness_options[] = {
    &straightness_step_mm,       &straightness_start_mm,       &straightness_stations,    &straightness_passes,
    &straightness_start,         &straightness_return_gap_s,   &straightness_min_dwell_s, &straightness_max_hole_s,
    &straightness_settle_arcsec, &straightness_pitch_channel,  &straightness_yaw_channel, &straightness_pitch_sign,
    &straightness_yaw_sign,      &straightness_angle_u_arcsec, &straightness_max_order,   &straightness_axis};
inline constexpr SessionKindInfo straightness_kind{
    "straightness", "autocollimator traverse: straightness from the station angles", straightness_options};

inline constexpr const SessionOption* profile_options[] = {&profile_wavelet, &profile_mode, &profile_level,
                                                           &profile_feed_mm_per_min, &profile_spindle_rpm};
inline constexpr SessionKindInfo profile_kind{
    "profile", "one profilometer traverse: straightness of the profile and its wavelet decomposition", profile_options};

// Every kind, in the order results are shown (fleet, report): dbb, runout, straightness, profile.
std::span<const SessionKindInfo* const> session_kinds();
// The kind named `name`; nullptr for an unknown one.
const SessionKindInfo* find_session_kind(std::string_view name);
// Throws std::out_of_range for an unknown name.
const SessionKindInfo& session_kind(std::string_view name);
// "dbb, runout, straightness, profile"
std::string session_kind_names();
// The place of a kind in session_kinds(); the number of kinds for an unknown one (shown last).
int session_kind_rank(std::string_view name);

// "step_mm=50": an option with its default ("patterns" for one without a short default).
std::string option_with_default(const SessionOption& option);
// The summary and every option with its default: "DBB circular test ... (options: patterns, plane=xy, ...)".
std::string description(const SessionKindInfo& kind);
// The headline figures of the kind's PARAMS (parameters.hpp), in their order.
std::span<const Parameter* const> headlines(const SessionKindInfo& kind);

}  // namespace guideway::results
