#pragma once
// Compensation from a DBB identification: the error map of the two plane axes (positioning error moving
// forward and in reverse, straightness across), the squareness, and the files a controller loads
// (LinuxCNC per-joint tables, the INI lines, the generic errors.csv; docs/compensation.md).
//
// The map is built from the ballbar diagnostics (models/dbb identify, docs/conventions.md), in machine
// coordinates: the circle centre places the terms, which the diagnostics give about the centre. A DBB
// test sees no constant offset of an axis, so every positioning error is relative to the axis' position
// at the circle centre. A term not larger than twice its standard uncertainty (k = 2) is not applied
// (its correction would be mostly noise), nor one the runs cannot have determined, nor one that contradicts
// EXPLAIN's value of it on the same runs; the files say so.
// Pure functions; thread safe.

#include <array>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "formats/dbb_run.hpp"
#include "models/dbb/identify.hpp"
#include "models/dbb/three_planes.hpp"
#include "models/explain/dbb_checked.hpp"

namespace guideway::models::compensation {

class CompensationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// How one identified term is used.
enum class Use {
  table,          // in the axis' per-joint table (and errors.csv)
  map_only,       // in errors.csv; a per-joint table cannot hold it (squareness: the controller's axis skew)
  cross_table,    // in straightness.csv (and errors.csv): a correction of the other plane axis by this one's position
  not_geometric,  // a servo or friction effect: neither table nor map (servo mismatch, reversal spike, ...)
};

struct Term {
  std::string name;  // the diagnostic's name, unit in the name ("backlash_x_um")
  double value = 0.0;
  double u = 0.0;            // standard uncertainty
  bool significant = false;  // |value| > 2 u
  Use use = Use::table;
  std::string why;  // for map_only / not_geometric: what the user does with it
  // Not a measurement (determined() false): the runs cannot have given it; `value` and `u` are then no
  // numbers to print.
  bool determined = true;
  // Non-empty: it contradicts another identification of the same runs (EXPLAIN's) beyond their
  // uncertainties, and says so.
  std::string contradiction;
  // Applied (written into a table or the map, entered as skew) only when significant, determined and
  // not contradicted.
  [[nodiscard]] bool applied() const { return significant && determined && contradiction.empty(); }
};

// The errors of one plane axis on the table's grid.
struct AxisMap {
  std::string axis;                     // "x"
  std::string across;                   // the other plane axis (direction of the straightness)
  std::vector<double> nominal_m;        // ascending, machine coordinates
  std::vector<double> forward_m;        // positioning error (actual - nominal) moving in +
  std::vector<double> reverse_m;        // moving in -
  std::vector<double> straightness_m;   // displacement along `across` (ends relative to the middle)
  bool straightness_applied = false;    // a significant straightness term: straightness.csv corrects it
  std::vector<double> table_forward_m;  // what the table holds: forward_m with the cyclic part
  std::vector<double> table_reverse_m;  // scaled by cyclic_table_gain
};

// The positioning error model of one axis (the applied terms only).
struct AxisTerms {
  double center_m = 0.0;  // circle centre along this axis (machine coordinates)
  double radius_m = 0.0;
  double scale = 0.0;  // relative (not ppm)
  double backlash_m = 0.0;
  double cyclic_amplitude_m = 0.0, cyclic_period_m = 0.0, cyclic_phase_rad = 0.0;
  double bow_m = 0.0;  // straightness bow B: displacement across = B ((u - centre) / r)^2
  // Cubic straightness k: displacement across += k (u - centre)^3. One circle sees only the difference of
  // the two axes' cubics (a sin 4 theta; their sum reads as squareness): it is split evenly between them,
  // exact on the circle; Lai's model over several radii gives each axis its own (docs/compensation.md).
  double cubic_per_m2 = 0.0;
  // LinuxCNC interpolates linearly between table lines, which scales a sinusoid of period p sampled
  // every step h by sinc^2(h / p) (the triangle kernel's response); the table's cyclic part is
  // multiplied by the inverse so the correction's fundamental has the measured amplitude. 0 = the
  // period is shorter than two steps: the table cannot hold it.
  double cyclic_table_gain = 1.0;
  // actual - nominal at `position_m` moving in `direction` (+1 / -1), relative to the centre.
  [[nodiscard]] double positioning_error_m(double position_m, int direction) const;
  [[nodiscard]] double straightness_m(double position_m) const;
  [[nodiscard]] double cyclic_m(double position_m) const;
};

struct ErrorMap {
  std::string plane;  // "xy", "xz", "yz"
  // The identification the map comes from: "diagnostics" (in-plane runs both ways) or "lai3" (Lai's
  // third-order model, e.g. of his tilted-bar patterns; its terms are renamed as the diagnostics').
  std::string model = "diagnostics";
  std::vector<std::string> notes;     // what the model could not give or the map leaves out, and why
  std::array<AxisTerms, 2> terms_of;  // per plane axis
  std::array<AxisMap, 2> axes;
  double squareness_rad = 0.0;  // actual (a, b) = (a + q b, b): the b axis leans towards +a
  double squareness_u_rad = 0.0;
  bool squareness_significant = false;
  bool squareness_known = false;
  std::vector<Term> terms;           // every identified term considered
  std::vector<std::string> sources;  // run files
  double step_m = 0.0;
  // What the terms were checked against: the runs' largest circular deviation G and fastest feed
  // (determined()), and MapOptions::cross_check.
  double circular_deviation_um = 0.0;
  double feed_m_per_s = 0.0;
  std::vector<dbb::Estimate> cross_check;
  // What was fitted beside the terms (explain::CheckedIdentification: the identification's `beside`), for people's
  // text.
  std::vector<dbb::Estimate> beside;
};

// Whether an identified term is a measurement at all: not when its size on the circle (um; a ppm or urad
// term times the radius, a servo mismatch times the feed) exceeds ten times the largest circular deviation
// G of the runs, nor when its uncertainty's size exceeds G (a value and u of orders more than the runs
// deviate: a spike of -256 +/- 150 um on runs of G 0.73 um). A name of another unit is taken as determined.
bool determined(const std::string& name, double value, double u, double g_um, double radius_m, double feed_m_per_s);

// Whether a reversal spike seen on the runs retraced with the map's tables (`after`) is the tables' own backlash
// step rather than the machine's stiction: the axis' table holds a backlash (applied), the runs before showed no
// spike (|value| not above 2 u), and after it is significant with the sign of an axis turning back early
// (negative; stiction holds the axis back: positive). A controller switches a per-joint table between its
// forward and reverse columns by the commanded velocity (LinuxCNC's COMP_FILE), so the backlash step is taken at
// the commanded reversal while the drive still lags its command by the servo lag: the drive crosses its deadband
// before reaching its extreme and the carriage turns back early (on config/machine-example.toml's standard test,
// 30 ms lag, 1000 mm/min: a dip of 0.83 um for Y's 2 um over some 50 ms). No table removes it; velocity
// feed-forward, or a reversal timing of the backlash step, does.
bool spike_from_backlash_step(const ErrorMap& map, const dbb::Estimate& before, const dbb::Estimate& after);

struct MapOptions {
  // Circle centre in machine coordinates (first, second plane axis); else every run's center_a_mm /
  // center_b_mm metadata (they must agree). Neither: CompensationError.
  std::optional<std::array<double, 2>> center_m;
  double step_m = 0.0;  // table spacing; 0 = the finest of 0.1, 0.2, 0.25, 0.5, 1, 2, 2.5, 5, ... mm within 256 lines
  // Another identification of the same runs (EXPLAIN's findings, explain::CheckedIdentification::explain): a term of
  // the same name that differs from it by more than 3 combined standard uncertainties is not applied.
  std::vector<dbb::Estimate> cross_check;
};

// error_map of a checked identification: EXPLAIN's values are the cross-check, and the notes of the
// identification (what was fitted beside) are the map's too.
ErrorMap error_map(const explain::CheckedIdentification& checked, const std::vector<formats::DbbRun>& runs,
                   MapOptions options = {});

// The circle centre of the runs' metadata (first, second plane axis), or nullopt when a run does not
// state it; throws CompensationError when the runs state different centres.
std::optional<std::array<double, 2>> runs_center_m(const std::vector<formats::DbbRun>& runs);

// What error_map checks before it looks at an identification (so a caller can refuse bad input before
// identifying): the runs go both ways, the centre (the options' or the runs') is known and a machine
// position, the step is positive and gives at most 256 lines. Throws CompensationError; returns the centre.
std::array<double, 2> check_map_inputs(const std::vector<formats::DbbRun>& runs, const MapOptions& options);

// From the ballbar diagnostics when the identification has them, else from Lai's third-order model
// (scale, backlash, the in-plane straightness polynomials, squareness a1; over the largest radius).
// Throws CompensationError when the runs do not go both ways, when the identification has neither,
// when the centre is unknown, or when the step gives more than 256 lines.
ErrorMap error_map(const dbb::Identification& id, const std::vector<formats::DbbRun>& runs,
                   const MapOptions& options = {});

// Lai's third-order parameters as the terms of the map, named and scaled as the diagnostics
// (scale_x_ppm = (S_x - 1) 1e6, straightness_x_um = a2 r^2, straightness_cubic_x_um = a3 r^3,
// squareness_urad = a1, ...; x / y are Lai's a / b, renamed to the plane's axes), at radius r; `notes`
// gets what the runs could not identify and what the map leaves out.
std::vector<dbb::Estimate> lai3_terms(const dbb::Identification& id, double radius_m, std::vector<std::string>& notes);

// The map term (diagnostics' name, as lai3_terms names it) a Lai parameter feeds, "" for none.
std::string lai3_term_of(const std::string& lai_name, const std::string& plane);

// Squareness as a user enters it: um of the first axis per metre of the second, and the correction
// (um) to add to the first axis per +100 mm of the second.
struct SquarenessAdvice {
  double um_per_m = 0.0;
  double correction_um_per_100mm = 0.0;
};
SquarenessAdvice squareness_advice(double squareness_rad);

// The files of `guideway compensate`, by name: "<axis>.comp" per plane axis, "linuxcnc.ini", "errors.csv",
// and "straightness.csv" when a straightness term is significant (the cross-axis correction).
struct OutputFile {
  std::string name;
  std::string content;
};
// `source` names the session or runs in the headers.
std::vector<OutputFile> compensation_files(const ErrorMap& map, const std::string& source);
// The files of a test in several planes (one map per plane): each axis' table once (from the first plane
// that sees it: use_machine_figures makes its planes' tables the same), errors.csv with every axis and
// every plane's squareness, straightness.csv with every plane's cross-axis rows.
std::vector<OutputFile> compensation_files(const std::vector<ErrorMap>& planes, const std::string& source);

// A test in several planes (models/dbb/three_planes): every axis' scale and backlash in each plane's map
// replaced by the planes' combined figure (`summary`, their inverse-variance mean; applied when larger
// than twice its u), so an axis seen by two planes gets one table. A figure whose planes disagree is
// refused: it is applied in no plane's map (its term's contradiction names the planes and by how much) and
// returned; the rest of the axis' table stands. The maps' notes say what was combined.
struct RefusedFigure {
  std::string name;  // "scale_y_ppm"
  std::string axis;
  std::string why;  // the summary's note
};
std::vector<RefusedFigure> use_machine_figures(std::vector<ErrorMap>& planes, const dbb::PlanesSummary& summary);
// Every name compensation_files can give (x.comp, y.comp, z.comp, linuxcnc.ini, errors.csv,
// straightness.csv), and each with do_not_load_suffix (a file a verification refused): what a new set
// written to a directory replaces.
std::vector<std::string> compensation_file_names();
inline constexpr std::string_view do_not_load_suffix = ".do-not-load";

// Why a term is not applied (not determined, contradicting EXPLAIN, not significant), "" when it is.
std::string left_out_because(const Term& t);
// The same for people: a contradiction of EXPLAIN with EXPLAIN's value rounded to its u, in its unit.
std::string left_out_in_words(const Term& t, const ErrorMap& m);

// The text summary `guideway compensate` prints (terms, what was applied, squareness advice).
std::string to_text(const ErrorMap& map);

// LinuxCNC joint number of a machine axis with trivial kinematics (x 0, y 1, z 2).
int joint_of(const std::string& axis);

}  // namespace guideway::models::compensation
