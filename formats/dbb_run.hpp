#pragma once
// DBB run files (docs/formats.md, "DBB run"): CSV with `# key = value` metadata lines, a header row
// `t_s,angle_deg,dL_um[,extra...]`, then one row per sample. Reading validates the file and the run
// (metadata present and consistent, finite numbers, monotonic angles in the stated direction) and
// reports errors as "file:line: message"). A run's data arc is a full circle or a partial arc of at
// least 180 deg (a vertical plane's 220 deg arc), optionally stated as `data_arc_deg`; samples missing
// inside it (a dropout) are gaps, found and described by dbb_run_gaps(), never a reason to refuse the run
// unless what is left covers less than 180 deg or has fewer than 72 samples. Pure functions; thread safe.
// It scans the CSV itself rather than through core/csv_table because it names the line of every
// metadata key it refuses and refuses a key given twice, which the generic reader does not track.

#include <cstddef>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace guideway::formats {

inline constexpr const char* dbb_run_format_id = "guideway/dbb-run/1";

class DbbRunFormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class DbbDirection { ccw = 1, cw = -1 };

// One DBB run in SI units.
struct DbbRun {
  std::string source;  // file name (for messages)
  double radius_m = 0.0;
  double height_m = 0.0;
  DbbDirection direction = DbbDirection::ccw;
  double feed_m_per_s = 0.0;
  std::string plane = "xy";  // xy | xz | yz
  double center_a_m = 0.0;   // optional: circle centre in machine coordinates (cyclic error phase)
  double center_b_m = 0.0;
  double data_arc_rad = 0.0;  // optional `data_arc_deg`: the arc the test commanded samples on (0 = not stated)
  std::map<std::string, std::string> metadata;  // every `# key = value` line, verbatim
  std::vector<double> t_s;
  std::vector<double> angle_rad;  // commanded angle zeta, unwrapped (monotonic)
  std::vector<double> dL_m;
  // Columns written after dL_um, one value per sample each (a controller's commanded position beside the
  // reading: "x_cmd_mm"); the reader ignores extra columns and leaves this empty.
  std::vector<std::pair<std::string, std::vector<double>>> extra_columns;
  [[nodiscard]] int dir() const { return static_cast<int>(direction); }
  [[nodiscard]] double nominal_length_m() const;
};

// The plausible range of a run's quantities (docs/formats.md, "DBB runs"): a value outside is refused at
// its line, naming the range. Metadata keys not listed have checks of their own (data_arc_deg,
// nominal_length_mm) or are not numbers.
struct DbbPlausible {
  std::string_view key;
  double min;
  bool min_open;  // (min, ...] rather than [min, ...]
  double max;
  std::string_view unit;
  std::string_view what;  // why the range
};
inline constexpr DbbPlausible dbb_plausible_metadata[] = {
    {"radius_mm", 0, true, 2000, "mm", "a ballbar's radius (bars with extensions reach 1.5 m)"},
    {"height_mm", 0, false, 2000, "mm", "the height of a tilted bar's socket above its centre ball"},
    {"feed_mm_per_min", 0, true, 200000, "mm/min", "a machine tool's feed (200 m/min)"},
    {"center_a_mm", -100000, false, 100000, "mm", "a machine tool's travel (100 m)"},
    {"center_b_mm", -100000, false, 100000, "mm", "a machine tool's travel (100 m)"},
    {"start_time_s", -1e10, false, 1e10, "s", "a clock's time (300 years)"},
    {"feed_in_deg", 0, false, 360, "deg", "an arc of the circle"},
    {"feed_out_deg", 0, false, 360, "deg", "an arc of the circle"},
    {"overshoot_deg", 0, false, 360, "deg", "an arc of the circle"},
    {"temperature_c", -50, false, 150, "degC", "a workshop's temperature"},
};
// The columns t_s, angle_deg, dL_um: each within +-max.
inline constexpr DbbPlausible dbb_plausible_columns[] = {
    {"t_s", 0, false, 1e6, "s", "a test's time (11 days)"},
    {"angle_deg", 0, false, 3600, "deg", "a circle's angle, unwrapped or not (10 turns)"},
    {"dL_um", 0, false, 1000, "um", "a bar length within 1 mm of sqrt(radius_mm^2 + height_mm^2)"},
};
// A header row's columns at most.
inline constexpr std::size_t dbb_max_columns = 4096;

// The least arc a run may cover, what is left of it after its gaps, and the fewest samples.
inline constexpr double dbb_min_arc_deg = 180.0;
inline constexpr std::size_t dbb_min_samples = 72;

// A dropout: consecutive samples further apart than the run's sampling (more than 5 times the median
// step and more than 0.5 deg), between sample `after` and the next.
struct DbbGap {
  std::size_t after = 0;                // index of the last sample before the gap
  double from_rad = 0.0, to_rad = 0.0;  // commanded angles either side (unwrapped, as in the run)
  double from_s = 0.0, to_s = 0.0;      // times either side
  [[nodiscard]] double angle_rad() const { return to_rad > from_rad ? to_rad - from_rad : from_rad - to_rad; }
  [[nodiscard]] double duration_s() const { return to_s - from_s; }
};
std::vector<DbbGap> dbb_run_gaps(const DbbRun& run);
// The arc the run's samples span (first to last, plus one regular step: a full circle is 2 pi), and what
// of it the samples cover (less the gaps).
double dbb_run_arc_rad(const DbbRun& run);
double dbb_run_covered_rad(const DbbRun& run);
[[nodiscard]] inline bool dbb_run_full_circle(const DbbRun& run) {
  return dbb_run_arc_rad(run) >= 359.0 / 180.0 * 3.141592653589793;
}
// "gap of 10.8 deg (1.10 s) from 120.3 to 131.1 deg (t 7.22 to 8.32 s, after sample 1203)".
std::string describe_gap(const DbbGap& gap);

// Parses and validates; throws RunFormatError naming the file and line.
DbbRun parse_dbb_run(const std::string& text, const std::string& source);
DbbRun read_dbb_run(const std::string& path);

// Checks a run built in memory (the same checks as parse_run); throws RunFormatError.
void validate_dbb_run(const DbbRun& run);

// Writes a run (angle in degrees, dL in um) with its metadata; extra metadata lines are kept.
std::string format_dbb_run(const DbbRun& run);
void write_dbb_run(const DbbRun& run, const std::string& path);

}  // namespace guideway::formats
