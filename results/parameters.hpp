#pragma once
// The catalogue of the parameters results report: each one's name, the unit it carries at the end of
// that name, where a result holds it, how it is shown to people, and whether it is one of its session
// kind's headline figures. Identification (models/dbb), EXPLAIN's effects, compensation, the fleet's
// headlines and the report name a parameter through its entry here, so a name is spelled once (the DBB
// ones' signs and meaning: docs/conventions.md; where a new one goes: docs/architecture.md). Pure; thread
// safe.
//
// A name may hold placeholders, filled by name():
//   {axis}  a plane axis the caller picks (0: the plane's first axis, 1: its second; or a given name,
//           "bar" for EXPLAIN's vibration along the bar); in a label a one-letter axis is a capital
//   {a} {b} the plane's first and second axis ("xz": x and z)
//   {A} {B} {N} in labels: the plane's first and second axis and its normal, as capitals ("xz": X, Z, Y);
//           Lai's names say x and y for the plane's axes whatever the plane, their labels say which
//   {run}   a run's number, from 1
//
// How a value is shown to people (shown()): its label, its unit (the name's end, or `shown_as` where
// the reported unit means little to a reader: a scale factor as ppm off 1, Lai's coefficients per mm
// as micrometres per metre), and the value rounded to its uncertainty (core/number_format.hpp).

#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>

namespace guideway::results {

// The unit a value is shown in when it is not the one its name ends with: shown = (value - offset) * factor.
struct ShownAs {
  std::string_view unit;  // "" = the name's own unit
  double factor = 1.0;
  double offset = 0.0;
};

// The groups of a DBB identification's PARAMS its quantities are reported in (Parameter::group, Place::group).
inline constexpr std::string_view diagnostics_group = "diagnostics";  // the ballbar diagnostics
inline constexpr std::string_view lai3_group = "lai3";                // Lai's third-order model
inline constexpr std::string_view ranking_group = "ranking";          // the errors "what to fix first" ranks from Lai's
inline constexpr std::string_view planes_group = "planes";            // the machine across its test planes ("summary")

// A group a quantity is reported in besides its entry's own, and what it is called there: one entry per physical
// quantity, with the places it appears as attributes (a DBB backlash is the diagnostics' backlash_z_um, Lai's
// backlash_x_um, "what to fix first"'s backlash_x and the machine's backlash_z_um across its planes).
// Its name there has the placeholders of Parameter::name, and {lai}: Lai's x or y for the plane's first or
// second axis, whatever the plane.
struct Place {
  std::string_view group;
  std::string_view name;
  std::string_view label = {};        // for people there; "" = the entry's
  std::string_view meaning = {};      // what it is there; "" = the entry's
  std::string_view shown_after = {};  // in its group's rows for people: after this name; "" = in catalogue order
};

struct Parameter {
  std::string_view name;     // as reported, unit last: "backlash_{axis}_um"
  std::string_view label;    // for people, with the same placeholders: "backlash {axis}"
  std::string_view kind;     // the session kind whose results hold it ("dbb", "runout", ...)
  std::string_view group;    // the PARAMS object it is in ("diagnostics", "lai3", ...); "" = EXPLAIN or the map only
  std::string_view meaning;  // what it is, one line
  int headline = 0;          // its place among its kind's headline figures (fleet, docs/plant.md); 0 = not one
  std::span<const Place> places = {};  // where else it is reported, in the order a reader looks for it there
  std::string_view figure_name = {};   // the name of its figure in `group` when not `name` (a headline named apart)
  ShownAs shown_as = {};               // how people read it, when not in the name's unit
};

// ---- DBB: the ballbar diagnostics (models/dbb identify; docs/conventions.md) ----------------------------
inline constexpr Parameter circular_deviation{"circular_deviation_um",
                                              "G",
                                              "dbb",
                                              "diagnostics",
                                              "ISO 230-4 circular deviation: the largest range of a run's reading "
                                              "about its least-squares circle",
                                              1};
inline constexpr Parameter circular_hysteresis{"circular_hysteresis_um", "circular hysteresis H", "dbb", "diagnostics",
                                               "ISO 230-4 hysteresis between a CCW and a CW run of one set-up"};
// ---- DBB: the standards' figures (models/dbb/standard_figures.hpp; docs/standards.md), per run and per
// CCW/CW pair in PARAMS' "standards" object, each with its test conditions ------------------------------
inline constexpr Parameter iso_circular_deviation{"iso_circular_deviation_um", "ISO 230-4 circular deviation G", "dbb",
                                                  "standards",
                                                  "range of a run's reading about its own least-squares circle"};
inline constexpr Parameter iso_radial_deviation_max{
    "iso_radial_deviation_max_um", "ISO 230-4 radial deviation F max", "dbb", "standards",
    "largest deviation of a run's path from the nominal radius, about its least-squares centre"};
inline constexpr Parameter iso_radial_deviation_min{
    "iso_radial_deviation_min_um", "ISO 230-4 radial deviation F min", "dbb", "standards",
    "smallest deviation of a run's path from the nominal radius, about its least-squares centre"};
inline constexpr Parameter asme_circularity{"asme_circularity_um", "ASME B5.54 circularity", "dbb", "standards",
                                            "one direction's range about its least-squares circle"};
inline constexpr Parameter iso_circular_hysteresis{
    "iso_circular_hysteresis_um", "ISO 230-4 circular hysteresis H", "dbb", "standards",
    "largest difference of a CCW and a CW run at one angle, about their common least-squares circle"};
inline constexpr Parameter iso_bidirectional_deviation{
    "iso_bidirectional_deviation_um", "ISO 230-4 bidirectional circular deviation G(b)", "dbb", "standards",
    "range of a CCW and a CW run together about their common least-squares circle"};
inline constexpr Parameter asme_hysteresis{"asme_hysteresis_um", "ASME B5.54 hysteresis", "dbb", "standards",
                                           "largest difference of the two directions at one angle"};
inline constexpr Parameter asme_bidirectional_circularity{
    "asme_bidirectional_circularity_um", "ASME B5.54 bidirectional circularity", "dbb", "standards",
    "range of both directions together about their common least-squares circle"};
inline constexpr Parameter center_offset{"center_offset_{axis}_um", "centre offset {axis}", "dbb", "diagnostics",
                                         "offset of the bar's fixed ball from the circle centre (per run: run{run}.)"};
// Lai's model and "what to fix first" say x and y for the plane's axes (Lai's a and b); the machine across its
// planes (models/dbb/three_planes) names the plane or the machine axis. Lai's backlash and servo mismatch are
// listed among Lai's terms after the last straightness coefficient, e3.
inline constexpr Place squareness_places[] = {
    {planes_group, "squareness_{a}{b}_urad", "squareness {A}{B}",
     "out-of-squareness of the plane's axes (its second leans towards its first)"}};
inline constexpr Parameter squareness{"squareness_urad",
                                      "squareness",
                                      "dbb",
                                      diagnostics_group,
                                      "out-of-squareness of the plane's axes (the second leans towards the first)",
                                      2,
                                      squareness_places};
inline constexpr Place backlash_places[] = {
    {lai3_group, "backlash_{lai}_um", {}, "Lai's backlash of the plane's axis a or b", "e3_per_mm2"},
    {ranking_group, "backlash_{lai}", {}, "Lai's backlash of the plane's axis a or b"},
    {planes_group, "backlash_{axis}_um", {}, "the axis' backlash from every plane that sees it (their weighted mean)"}};
inline constexpr Parameter backlash{
    "backlash_{axis}_um", "backlash {axis}", "dbb", diagnostics_group, "lost motion of the axis at a reversal", 3,
    backlash_places};
inline constexpr Place scale_places[] = {{planes_group,
                                          "scale_{axis}_ppm",
                                          {},
                                          "the axis' scale error from every plane that sees it (their weighted mean)"}};
inline constexpr Parameter scale{
    "scale_{axis}_ppm", "scale {axis}", "dbb", diagnostics_group, "length scale error of the axis", 4, scale_places};
inline constexpr Place scale_mismatch_places[] = {
    {ranking_group, "scale_mismatch", {}, "Lai's S_x and S_y: their difference (what they share is the radius)"},
    {planes_group, "scale_mismatch_{a}{b}_ppm", "scale mismatch {A}{B}",
     "difference of the plane's axes' scales (first minus second)"}};
inline constexpr Parameter scale_mismatch{"scale_mismatch_ppm",
                                          "scale mismatch",
                                          "dbb",
                                          diagnostics_group,
                                          "difference of the plane axes' scales (first minus second)",
                                          0,
                                          scale_mismatch_places};
inline constexpr Parameter lateral_play{"lateral_play_{axis}_um", "lateral play {axis}", "dbb", "diagnostics",
                                        "sideways shift of the carriage when its direction of travel changes"};
inline constexpr Place servo_mismatch_places[] = {
    {lai3_group, "servo_mismatch_ms", {}, "Lai's servo lag difference of axis a behind b", "e3_per_mm2"},
    {ranking_group, "servo_mismatch", {}, "Lai's servo lag difference"}};
inline constexpr Parameter servo_mismatch{"servo_mismatch_ms",
                                          "servo mismatch",
                                          "dbb",
                                          diagnostics_group,
                                          "lag of the first axis' position loop behind the second's",
                                          0,
                                          servo_mismatch_places};
inline constexpr Parameter straightness_bow{"straightness_{axis}_um", "straightness {axis}", "dbb", "diagnostics",
                                            "bow of the axis across the plane at the circle's radius"};
inline constexpr Parameter reversal_spike{"reversal_spike_{axis}_um", "reversal spike {axis}", "dbb", "diagnostics",
                                          "height of the stiction spike after the axis reverses"};
inline constexpr Parameter reversal_spike_decay{"reversal_spike_decay_{axis}_ms", "reversal spike decay {axis}", "dbb",
                                                "diagnostics", "decay time of the axis' reversal spike"};
inline constexpr Parameter reversal_spike_delay{"reversal_spike_delay_{axis}_ms", "reversal spike delay {axis}", "dbb",
                                                "diagnostics", "delay of the spike after the commanded reversal"};
inline constexpr Parameter cyclic_sin{"cyclic_sin_{axis}_um", "cyclic error {axis} (sine)", "dbb", "diagnostics",
                                      "fit column: the cyclic error's sine part (reported as amplitude and phase)"};
inline constexpr Parameter cyclic_cos{"cyclic_cos_{axis}_um", "cyclic error {axis} (cosine)", "dbb", "diagnostics",
                                      "fit column: the cyclic error's cosine part"};
inline constexpr Parameter cyclic_error{"cyclic_error_{axis}_um", "cyclic error {axis}", "dbb", "diagnostics",
                                        "amplitude of the lead-screw (pitch) error repeating along the axis"};
inline constexpr Parameter cyclic_period{"cyclic_period_{axis}_mm", "cyclic period {axis}", "dbb", "diagnostics",
                                         "period of the cyclic error (the screw's lead)"};
inline constexpr Parameter cyclic_phase{"cyclic_phase_{axis}_deg", "cyclic phase {axis}", "dbb", "diagnostics",
                                        "phase of the cyclic error at position 0"};

// ---- DBB: Lai's third-order model (Lai 1997 Table 3 names; x, y are Lai's a, b whatever the plane) ------
// Shown in units a reader can picture: a straightness coefficient per mm^(k-1) as the micrometres it
// bends the axis over a metre (um/m^k), a roll coefficient as urad/m^k, an angle in urad, S - 1 in ppm.
inline constexpr ShownAs shown_um_per_m2{"\u00b5m/m\u00b2", 1e9};
inline constexpr ShownAs shown_um_per_m3{"\u00b5m/m\u00b3", 1e12};
inline constexpr ShownAs shown_urad{"\u00b5rad", 1e6};
inline constexpr ShownAs shown_urad_per_m{"\u00b5rad/m", 1e9};
inline constexpr ShownAs shown_urad_per_m2{"\u00b5rad/m\u00b2", 1e12};
inline constexpr ShownAs shown_ppm_off_one{"ppm", 1e6, 1.0};
inline constexpr Parameter lai_e_x{"e_x_um", "fixed ball offset {A}", "dbb", "lai3", "fixed ball offset along a"};
inline constexpr Parameter lai_e_y{"e_y_um", "fixed ball offset {B}", "dbb", "lai3", "fixed ball offset along b"};
inline constexpr Parameter lai_S_x{
    "S_x", "scale {A} (S_x - 1)", "dbb", "lai3", "scale factor of axis a (1 = exact)", 0, {}, {}, shown_ppm_off_one};
inline constexpr Parameter lai_S_y{
    "S_y", "scale {B} (S_y - 1)", "dbb", "lai3", "scale factor of axis b (1 = exact)", 0, {}, {}, shown_ppm_off_one};
inline constexpr Parameter lai_a1{"a1_rad",
                                  "{A} straightness along {B}, linear: squareness (a1)",
                                  "dbb",
                                  "lai3",
                                  "X straightness in b, linear: the squareness",
                                  0,
                                  {},
                                  {},
                                  shown_urad};
inline constexpr Parameter lai_a2{"a2_per_mm",
                                  "{A} straightness along {B}, quadratic (a2)",
                                  "dbb",
                                  "lai3",
                                  "X straightness in b, quadratic",
                                  0,
                                  {},
                                  {},
                                  shown_um_per_m2};
inline constexpr Parameter lai_a3{
    "a3_per_mm2",   "{A} straightness along {B}, cubic (a3)", "dbb", "lai3", "X straightness in b, cubic", 0, {}, {},
    shown_um_per_m3};
inline constexpr Parameter lai_b2{"b2_per_mm",
                                  "{B} straightness along {A}, quadratic (b2)",
                                  "dbb",
                                  "lai3",
                                  "Y straightness in a, quadratic",
                                  0,
                                  {},
                                  {},
                                  shown_um_per_m2};
inline constexpr Parameter lai_b3{
    "b3_per_mm2",   "{B} straightness along {A}, cubic (b3)", "dbb", "lai3", "Y straightness in a, cubic", 0, {}, {},
    shown_um_per_m3};
inline constexpr Parameter lai_c0_plus_d1{"c0_plus_d1_rad",
                                          "{B} roll + {A} straightness along {N}, linear (c0 + d1)",
                                          "dbb",
                                          "lai3",
                                          "Y roll and X straightness in n, linear (not separable)",
                                          0,
                                          {},
                                          {},
                                          shown_urad};
inline constexpr Parameter lai_c1{"c1_per_mm", "{B} roll, linear (c1)", "dbb", "lai3", "Y roll, linear", 0, {},
                                  {},          shown_urad_per_m};
inline constexpr Parameter lai_c2{"c2_per_mm2", "{B} roll, quadratic (c2)", "dbb", "lai3", "Y roll, quadratic", 0, {},
                                  {},           shown_urad_per_m2};
inline constexpr Parameter lai_d2{"d2_per_mm",
                                  "{A} straightness along {N}, quadratic (d2)",
                                  "dbb",
                                  "lai3",
                                  "X straightness in n, quadratic",
                                  0,
                                  {},
                                  {},
                                  shown_um_per_m2};
inline constexpr Parameter lai_d3{
    "d3_per_mm2",   "{A} straightness along {N}, cubic (d3)", "dbb", "lai3", "X straightness in n, cubic", 0, {}, {},
    shown_um_per_m3};
inline constexpr Parameter lai_e1{
    "e1_rad",  "{B} straightness along {N}, linear (e1)", "dbb", "lai3", "Y straightness in n, linear", 0, {}, {},
    shown_urad};
inline constexpr Parameter lai_e2{"e2_per_mm",
                                  "{B} straightness along {N}, quadratic (e2)",
                                  "dbb",
                                  "lai3",
                                  "Y straightness in n, quadratic",
                                  0,
                                  {},
                                  {},
                                  shown_um_per_m2};
inline constexpr Parameter lai_e3{
    "e3_per_mm2",   "{B} straightness along {N}, cubic (e3)", "dbb", "lai3", "Y straightness in n, cubic", 0, {}, {},
    shown_um_per_m3};
// Lai's backlash and servo mismatch: backlash's and servo_mismatch's places in lai3 (above).
inline constexpr Parameter lai_mismatch_phase_angle{"mismatch_phase_angle_deg",
                                                    "servo mismatch phase angle",
                                                    "dbb",
                                                    "lai3",
                                                    "Lai's phase angle of the servo mismatch at the first run's speed",
                                                    0,
                                                    {},
                                                    {},
                                                    {"\u00b5rad", 1e6 * std::numbers::pi / 180}};

// ---- DBB: the errors "what to fix first" ranks from Lai's model (its terms grouped by the error they
// describe; the diagnostics' ranking names the diagnostics above). The scale mismatch, the backlash and the
// servo mismatch are their entries' places in "ranking" (above) ----------------------------------------------
inline constexpr Parameter rank_straightness_ab{"x_straightness_in_y", "{A} straightness along {B}", "dbb", "ranking",
                                                "a1, a2, a3: the squareness with the straightness of axis a in b"};
inline constexpr Parameter rank_straightness_ba{"y_straightness_in_x", "{B} straightness along {A}", "dbb", "ranking",
                                                "b2, b3: the straightness of axis b in a"};
inline constexpr Parameter rank_straightness_an{"x_straightness_in_z", "{A} straightness along {N}", "dbb", "ranking",
                                                "d2, d3: the straightness of axis a along the plane's normal"};
inline constexpr Parameter rank_straightness_bn{"y_straightness_in_z", "{B} straightness along {N}", "dbb", "ranking",
                                                "e1, e2, e3: the straightness of axis b along the plane's normal"};
inline constexpr Parameter rank_roll_b{"y_roll", "{B} roll", "dbb", "ranking", "c1, c2: the roll of axis b"};
inline constexpr Parameter rank_roll_b_straightness_an{"y_roll_and_x_straightness_in_z",
                                                       "{B} roll and {A} straightness along {N}", "dbb", "ranking",
                                                       "c0 + d1, which no set of patterns separates"};

// ---- DBB: the machine across its test planes (models/dbb/three_planes): the squareness, scale mismatch, backlash
// and scale entries' places in "planes" (above) ---------------------------------------------------------------

// ---- DBB: terms of the compensation map only (models/compensation) ------------------------------------------
inline constexpr Parameter straightness_cubic{"straightness_cubic_{axis}_um", "cubic straightness {axis}", "dbb", "",
                                              "cubic part of the axis' straightness at the circle's radius"};
// ... and a diagnostic too: all a circle sees of the cubic straightness besides a squareness.
inline constexpr Parameter straightness_cubic_difference{
    "straightness_cubic_{a}_minus_{b}_um", "cubic straightness {A} - {B}", "dbb", "diagnostics",
    "difference of the plane axes' cubic straightness, all one circle determines"};

// ---- DBB: EXPLAIN's effect parameters besides the diagnostics' (models/explain/effects) -------------------
inline constexpr Parameter backlash_delay{"backlash_delay_ms", "backlash delay", "dbb", "",
                                          "how late the drives follow the command where the deadband is taken up"};
inline constexpr Parameter spike_decay{"reversal_spike_decay_ms", "reversal spike decay", "dbb", "",
                                       "decay time of the reversal spikes (searched)"};
inline constexpr Parameter compensation_step{
    "compensation_step_{axis}_um", "compensation step {axis}", "dbb", "",
    "the backlash a controller's table steps at the commanded reversal while the drive follows late"};
inline constexpr Parameter compensation_step_lag{"compensation_step_lag_ms", "compensation step lag", "dbb", "",
                                                 "how late the drive follows the compensation's step (searched)"};
// A line's sine and cosine parts: unit-amplitude columns, so each part is in um (fitted beside, shown).
inline constexpr ShownAs shown_um{"\u00b5m"};
inline constexpr Parameter cyclic_sin_column{"cyclic_sin_{axis}",
                                             "cyclic error {axis} (sine)",
                                             "dbb",
                                             "",
                                             "fit column: the cyclic error's sine part",
                                             0,
                                             {},
                                             {},
                                             shown_um};
inline constexpr Parameter cyclic_cos_column{"cyclic_cos_{axis}",
                                             "cyclic error {axis} (cosine)",
                                             "dbb",
                                             "",
                                             "fit column: the cyclic error's cosine part",
                                             0,
                                             {},
                                             {},
                                             shown_um};
inline constexpr Parameter cyclic_delay{"cyclic_delay_{axis}_ms", "cyclic delay {axis}", "dbb", "",
                                        "how late the drive follows the command where the cyclic error lives"};
inline constexpr Parameter bar_drift{"bar_drift_um_per_min", "bar drift", "dbb", "",
                                     "growth of the bar's reading with time"};
inline constexpr Parameter bar_drift_offset{"bar_drift_offset_run{run}_um", "bar drift offset run {run}", "dbb", "",
                                            "the bar's reading offset of a run without a common clock"};
inline constexpr Parameter centre_drift{"drift_{axis}_um_per_min", "centre drift {axis}", "dbb", "",
                                        "drift of the circle's centre along the axis with time"};
inline constexpr Parameter centre_drift_offset{"drift_{axis}_offset_run{run}_um", "centre offset {axis} run {run}",
                                               "dbb", "", "the centre's offset of a run without a common clock"};
inline constexpr Parameter vibration_sin{"vibration_sin",
                                         "vibration (sine)",
                                         "dbb",
                                         "",
                                         "fit column: the vibration's sine part (_runK: one run's)",
                                         0,
                                         {},
                                         {},
                                         shown_um};
inline constexpr Parameter vibration_cos{"vibration_cos",
                                         "vibration (cosine)",
                                         "dbb",
                                         "",
                                         "fit column: the vibration's cosine part (_runK: one run's)",
                                         0,
                                         {},
                                         {},
                                         shown_um};
// A vibration fitted beside the models' terms (PARAMS' "beside", next to its parts): A sin(2 pi f t + phi).
inline constexpr Parameter beside_vibration{
    "vibration_amplitude_um", "vibration amplitude", "dbb", "beside",
    "amplitude of the vibration fitted beside, along the direction EXPLAIN found it (_runK: one run's)"};
inline constexpr Parameter beside_vibration_phase{
    "vibration_phase_deg", "vibration phase at t = 0", "dbb", "beside",
    "its phase at t = 0 of the runs' clock, the earliest run's start (_runK: that run's own start), at EXPLAIN's "
    "frequency: its u leaves out the frequency's, which EXPLAIN's vibration phase includes"};
inline constexpr Parameter vibration{"vibration_{axis}_um", "vibration {axis}", "dbb", "",
                                     "amplitude of a vibration along the axis (or the bar)"};
inline constexpr Parameter vibration_phase{"vibration_phase_{axis}_deg", "vibration phase {axis}", "dbb", "",
                                           "its phase at time 0 (_runK: of one run)"};
inline constexpr Parameter vibration_frequency{"vibration_hz", "vibration frequency", "dbb", "",
                                               "frequency of the vibration"};
inline constexpr Parameter stick_slip{"stick_slip_{axis}_um", "stick-slip {axis}", "dbb", "",
                                      "amplitude of the jerks after the axis reverses"};
inline constexpr Parameter stick_slip_frequency{"stick_slip_hz", "stick-slip frequency", "dbb", "",
                                                "frequency of the jerks (searched)"};
inline constexpr Parameter stick_slip_decay{"stick_slip_decay_ms", "stick-slip decay", "dbb", "",
                                            "decay time of the jerks (searched)"};
inline constexpr Parameter servo_lag{"servo_lag_ms", "servo lag", "dbb", "",
                                     "how late both drives follow the command (the position loops' 1/Kv)"};
inline constexpr Parameter sensor_quadratic{"sensor_quadratic_per_um", "sensor non-linearity (quadratic)", "", "",
                                            "the transducer's quadratic error per um of reading"};
inline constexpr Parameter sensor_cubic{"sensor_cubic_per_um2", "sensor non-linearity (cubic)", "", "",
                                        "the transducer's cubic error"};

// ---- Profiles: EXPLAIN's effect parameters of a faced surface or a traverse (profile_explain) -----------------
inline constexpr Parameter abbe_offset{"abbe_offset_x_mm", "Abbe offset x", "profile", "",
                                       "offset of the tool from the carriage's measuring line"};
inline constexpr Parameter profile_drift{"thermal_drift_um_per_min", "thermal drift", "profile", "",
                                         "growth of the depth of cut with time"};
inline constexpr Parameter runout_sin{"runout_sin", "spindle axial run-out (sine)", "profile", "",
                                      "fit column: the run-out's sine part"};
inline constexpr Parameter runout_cos{"runout_cos", "spindle axial run-out (cosine)", "profile", "",
                                      "fit column: the run-out's cosine part"};
inline constexpr Parameter runout_per_rev{"spindle_axial_runout_per_rev", "run-out per revolution", "profile", "",
                                          "the run-out's harmonic of the spindle frequency (searched)"};
inline constexpr Parameter spindle_axial_runout{"spindle_axial_runout_um", "spindle axial run-out", "profile", "",
                                                "amplitude of the spindle's axial motion"};
inline constexpr Parameter spindle_axial_runout_phase{"spindle_axial_runout_phase_deg", "spindle run-out phase",
                                                      "profile", "", "its phase"};
inline constexpr Parameter tool_wear{"tool_wear_um_per_m", "tool wear", "profile", "",
                                     "loss of depth of cut per metre cut"};
inline constexpr Parameter nose_curvature{"nose_curvature_per_mm", "nose curvature", "profile", "",
                                          "fit column: the cusp's curvature"};
inline constexpr Parameter nose_curvature_quadrature{"nose_curvature_quadrature_per_mm", "nose curvature (quadrature)",
                                                     "profile", "", "fit column: the cusp's quadrature part"};
inline constexpr Parameter feed_marks{"feed_marks_um", "feed marks", "profile", "",
                                      "height of the cusps the tool nose leaves"};
inline constexpr Parameter tool_nose_radius{"tool_nose_radius_mm", "tool nose radius", "profile", "",
                                            "the nose radius the cusps give"};
inline constexpr Parameter profile_cyclic_sin{"cyclic_sin", "cyclic error x (sine)", "profile", "",
                                              "fit column: the X drive's cyclic error, sine part"};
inline constexpr Parameter profile_cyclic_cos{"cyclic_cos", "cyclic error x (cosine)", "profile", "",
                                              "fit column: the X drive's cyclic error, cosine part"};

// ---- The headline figures of the other session kinds -------------------------------------------------------
inline constexpr Parameter runout_squareness{"squareness_urad",
                                             "squareness (run-out)",
                                             "runout",
                                             "squareness",
                                             "squareness of the spindle to the table by Mu's Eq. 21",
                                             1};
inline constexpr Parameter runout{
    "runout_um", "run-out", "runout", "squareness", "once-per-revolution run-out on the thrust plate", 2};
// ---- Run-out: ISO 230-7 spindle error motion of the record (models/flatness/error_motion) -------------------
inline constexpr Parameter total_error_motion{
    "total_error_motion_um", "total error motion", "runout", "error_motion",
    "ISO 230-7 total error motion: peak-to-valley of the record, once-per-revolution term removed"};
inline constexpr Parameter synchronous_error_motion{
    "synchronous_error_motion_um", "synchronous error motion", "runout", "error_motion",
    "ISO 230-7 synchronous error motion: peak-to-valley of the average revolution, once-per-revolution term removed"};
inline constexpr Parameter asynchronous_error_motion{
    "asynchronous_error_motion_um", "asynchronous error motion", "runout", "error_motion",
    "ISO 230-7 asynchronous error motion: the widest spread across revolutions at one angle"};
inline constexpr Parameter fundamental_error_motion{
    "fundamental_um", "once-per-revolution term (removed)", "runout", "error_motion",
    "amplitude of the once-per-revolution sinusoid removed before the error motion values (the face's tilt)"};
inline constexpr Parameter spindle_synchronous_error_motion{
    "spindle_synchronous_error_motion_um", "spindle's synchronous error motion", "runout", "error_motion",
    "ISO 230-7 synchronous error motion of the spindle alone: the artifact's form removed by a reversal (Donaldson)"};
inline constexpr Parameter artifact_form_error{
    "artifact_form_um", "artifact's form", "runout", "error_motion",
    "peak-to-valley of the artifact's own form, separated from the spindle's by a reversal (Donaldson)"};
// ---- Run-out: EXPLAIN's effect parameters of a spindle run-out record (runout_explain) ---------------------
inline constexpr Parameter runout_order_sin{"order_sin", "line (sine)", "runout", "", "fit column: a line's sine part"};
inline constexpr Parameter runout_order_cos{"order_cos", "line (cosine)", "runout", "",
                                            "fit column: a line's cosine part"};
inline constexpr Parameter runout_order{"order_per_rev", "order", "runout", "",
                                        "a line's frequency in cycles per spindle revolution (searched)"};
inline constexpr Parameter synchronous_harmonic{"synchronous_harmonic_um", "synchronous harmonic", "runout", "",
                                                "amplitude of a harmonic that repeats every revolution"};
inline constexpr Parameter synchronous_harmonic_phase{"synchronous_harmonic_phase_deg", "synchronous harmonic phase",
                                                      "runout", "", "its phase"};
inline constexpr Parameter asynchronous_line{"asynchronous_line_um", "asynchronous line", "runout", "",
                                             "amplitude of a line at a non-integer order (a bearing defect)"};
inline constexpr Parameter asynchronous_line_phase{"asynchronous_line_phase_deg", "asynchronous line phase", "runout",
                                                   "", "its phase at the record's start"};
inline constexpr Parameter axial_growth{"axial_growth_um_per_min", "axial thermal growth", "runout", "",
                                        "growth of the spindle along its axis with time"};
inline constexpr Parameter speed_offset{"speed_offset_percent", "speed offset", "runout", "",
                                        "the spindle's speed above the nominal rpm"};
inline constexpr Parameter speed_ramp{"speed_ramp_percent_per_min", "speed ramp", "runout", "",
                                      "change of the spindle's speed with time"};
inline constexpr Parameter artifact_form{
    "artifact_form_harmonic_um", "artifact form harmonic", "runout", "",
    "amplitude of a harmonic of the artifact's own form (it turns with the artifact)"};
inline constexpr Parameter artifact_form_phase{"artifact_form_harmonic_phase_deg", "artifact form phase", "runout", "",
                                               "its phase from the spindle's zero in the first record"};
inline constexpr Parameter speed_ripple{"speed_ripple_percent", "speed ripple", "runout", "",
                                        "amplitude of a periodic ripple of the spindle's speed"};
inline constexpr Parameter speed_ripple_phase{"speed_ripple_phase_deg", "speed ripple phase", "runout", "",
                                              "its phase at the record's start"};
// ---- Traverses: EXPLAIN's effect parameters of autocollimator traverses (traverse_explain) ----------------
inline constexpr Parameter angle_drift{"angle_drift_arcsec_per_min", "angle drift", "straightness", "",
                                       "the pitch reading's zero drifting with time (instrument, air)"};
inline constexpr Parameter reflector_rocking{"reflector_rocking_arcsec", "reflector rocking", "straightness", "",
                                             "half the pitch difference moving + minus moving - (the reflector or "
                                             "carriage tilting with the direction of travel)"};
inline constexpr Parameter pitch_wave_sin{"pitch_wave_sin_arcsec", "pitch wave (sine)", "straightness", "",
                                          "fit column: a periodic pitch's sine part"};
inline constexpr Parameter pitch_wave_cos{"pitch_wave_cos_arcsec", "pitch wave (cosine)", "straightness", "",
                                          "fit column: a periodic pitch's cosine part"};
inline constexpr Parameter pitch_wave{"pitch_wave_arcsec", "periodic pitch", "straightness", "",
                                      "amplitude of a pitch that repeats along the axis (rack, lead screw)"};
inline constexpr Parameter pitch_wave_phase{"pitch_wave_phase_deg", "periodic pitch phase", "straightness", "",
                                            "its phase at x = 0"};
inline constexpr Parameter pitch_wave_period{"pitch_wave_period_mm", "periodic pitch period", "straightness", "",
                                             "its period along the axis (searched)"};
inline constexpr Parameter yaw_coupling{"yaw_coupling_percent", "yaw read as pitch", "straightness", "",
                                        "part of the yaw reading that the pitch reading holds (head or reflector "
                                        "turned about the beam)"};

inline constexpr Parameter horizontal_straightness{
    "horizontal_straightness_um",
    "straightness h",
    "straightness",
    "straightness",
    "least-squares straightness of the traverse in the horizontal plane (from the yaw)",
    1,
    {},
    "horizontal_least_squares_um"};
inline constexpr Parameter vertical_straightness{
    "vertical_straightness_um",
    "straightness v",
    "straightness",
    "straightness",
    "least-squares straightness of the traverse in the vertical plane (from the pitch)",
    2,
    {},
    "vertical_least_squares_um"};
inline constexpr Parameter profile_straightness{"straightness_lsq_um",
                                                "profile straightness",
                                                "profile",
                                                "profile",
                                                "least-squares straightness of the profile",
                                                1};
inline constexpr Parameter form_straightness{"form_straightness_um",
                                             "form straightness",
                                             "profile",
                                             "profile",
                                             "straightness of the profile's form (the wavelet approximation)",
                                             2};

// Every entry above, in this file's order.
std::span<const Parameter* const> catalogue();
// The entry a reported name is an instance of ("backlash_z_um", "run2.center_offset_x_um",
// "vibration_phase_bar_deg_run1"), by its own name or one of its places', the first in catalogue order; nullptr
// for a name not in the catalogue. With a group: the entry named so in that group first (Lai's "backlash_x_um" is
// backlash's place in lai3, the plane's first axis, not the diagnostics' backlash of the x axis).
const Parameter* find_parameter(std::string_view name, std::string_view group = {});

// The plane's axis `axis` (0 or 1) as it is written in names: "xz", 1 -> "z" (a plane not of two
// letters: x and y).
std::string axis_letter(std::string_view plane, int axis);
// The name with its placeholders filled: {axis} by the plane's axis `axis`, {a} and {b} by the plane's.
std::string name(const Parameter& p, std::string_view plane = "xy", int axis = -1);
// ... {axis} by `along` ("bar", "x"), {run} by `run` (from 1; 0: none).
std::string name_along(const Parameter& p, std::string_view along, int run = 0);
// Its name in `group`: its own in its group, else its place's there ({lai}: x or y for the plane's axis 0 or 1);
// "" when it is not reported in that group.
std::string name_in(const Parameter& p, std::string_view group, std::string_view plane = "xy", int axis = -1);
// Where a reported name comes among its group's rows for people: its entry's position in the catalogue, or where
// its place says (Place::shown_after); catalogue().size() for a name not in it.
double shown_order(std::string_view name, std::string_view group);
std::string label(const Parameter& p, std::string_view plane = "xy", int axis = -1);
// Whether the name holds {axis}: one figure per plane axis.
[[nodiscard]] bool per_axis(const Parameter& p);
// A name of one run among several: "run2.center_offset_x_um" (identification), "vibration_sin_run2" (EXPLAIN).
std::string run_prefixed(int run, const std::string& name);
std::string run_suffixed(const std::string& name, int run);

// The label of a reported name, placeholders filled from the name and the plane, a run's number after it:
// "run2.center_offset_x_um" -> "centre offset x (run 2)"; "y_straightness_in_z" -> "Y straightness along Z".
// The entry of `group` first (Lai's "backlash_y_um" is the plane's second axis, the diagnostics' the y
// axis); a name not in the catalogue in words ("horizontal_end_point_um" -> "horizontal end point").
std::string label_of(std::string_view name, std::string_view plane = "xy", std::string_view group = {});

// An identifier in words ("thermal_drift" -> "thermal drift"): an effect's or a group's name for people.
std::string in_words(std::string_view id);

// A reported value as people read it: the label, the value in the unit it is shown in, rounded to its
// uncertainty (GUM: u to two significant digits, the value to the same place; core/number_format.hpp).
struct Shown {
  std::string label;
  std::string value;  // "-10.01 \u00b1 0.34", "(2.211 \u00b1 0.013)e-7"; without u: `significant` digits
  std::string unit;   // "ppm", "\u00b5m/m\u00b2"; "" for a number without unit
};
Shown shown(std::string_view name, double value, double u, std::string_view plane = "xy", std::string_view group = {},
            int significant = 3);
// The unit the name's value is shown in, and the conversion from the reported value.
struct ShownUnit {
  std::string symbol;
  double factor = 1.0;
  double offset = 0.0;
};
ShownUnit shown_unit(std::string_view name, std::string_view group = {});

// The unit a name ends with, as reported ("_um" -> "µm"): the one table of unit suffixes.
// "name_um" -> ("name", "µm"); a name without a known suffix -> (name, "").
std::pair<std::string, std::string> split_unit(const std::string& name);
std::string unit(const Parameter& p);

// A line fitted as its sine and cosine parts (unit-amplitude columns sin theta, cos theta: a vibration, a
// cyclic error fitted beside): people read its amplitude A and phase phi, s sin theta + c cos theta =
// A sin(theta + phi) (models/common/amplitude_phase), the JSON keeps the parts beside them. The names of the
// line a reported part is of ("vibration_cos_run2" -> "vibration_sin_run2", "vibration_cos_run2",
// "vibration_amplitude_um_run2", "vibration_phase_deg_run2"; "cyclic_sin_x" -> ..., "cyclic_error_x_um",
// "cyclic_phase_x_deg"); nullopt for a name that is no line's part.
struct LineNames {
  std::string sine, cosine, amplitude, phase;
};
std::optional<LineNames> line_of_part(std::string_view part_name);
// What a line's phase is counted from, said once where people read the values.
inline constexpr std::string_view line_phase_reference =
    "amplitude A and phase \u03c6 are of A sin(\u03b8 + \u03c6): a vibration's \u03b8 = 2\u03c0 f t from t = 0 of "
    "the runs' clock (the earliest run's start; with a phase per run, that run's own start), a cyclic error's "
    "\u03b8 = 2\u03c0 x / lead from the axis at x = 0 (machine coordinates)";

// The headline figures of a session kind's PARAMS, in their order; empty for a kind without any.
std::span<const Parameter* const> headline_parameters(std::string_view kind);

}  // namespace guideway::results
