#pragma once
// DBB run files (docs/formats.md, "DBB run"): CSV with `# key = value` metadata lines, a header row
// `t_s,angle_deg,dL_um[,extra...]`, then one row per sample. Reading validates the file and the run
// (metadata present and consistent, finite numbers, a full circle in the stated direction) and
// reports errors as "file:line: message". Pure functions; thread safe.
// It scans the CSV itself rather than through core/csv_table because it names the line of every
// metadata key it refuses and refuses a key given twice, which the generic reader does not track.

#include <map>
#include <stdexcept>
#include <string>
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
  std::map<std::string, std::string> metadata;  // every `# key = value` line, verbatim
  std::vector<double> t_s;
  std::vector<double> angle_rad;  // commanded angle zeta, unwrapped (monotonic)
  std::vector<double> dL_m;
  [[nodiscard]] int dir() const { return static_cast<int>(direction); }
  [[nodiscard]] double nominal_length_m() const;
};

// Parses and validates; throws RunFormatError naming the file and line.
DbbRun parse_dbb_run(const std::string& text, const std::string& source);
DbbRun read_dbb_run(const std::string& path);

// Checks a run built in memory (the same checks as parse_run); throws RunFormatError.
void validate_dbb_run(const DbbRun& run);

// Writes a run (angle in degrees, dL in um) with its metadata; extra metadata lines are kept.
std::string format_dbb_run(const DbbRun& run);
void write_dbb_run(const DbbRun& run, const std::string& path);

}  // namespace guideway::formats
