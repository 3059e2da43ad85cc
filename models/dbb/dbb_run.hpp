#pragma once
// DBB run files (docs/formats.md, "DBB run"): CSV with `# key = value` metadata lines, a header row
// `t_s,angle_deg,dL_um[,extra...]`, then one row per sample. Reading validates the file and the run
// (metadata present and consistent, finite numbers, a full circle in the stated direction) and
// reports errors as "file:line: message". Pure functions; thread safe.
//
// TODO(core/csv_table): the generic `# key = value` CSV reading here should move to core/csv_table
// once that reader exists; only the DBB-specific validation belongs in this module.

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace guideway::models::dbb {

inline constexpr const char* run_format_id = "guideway/dbb-run/1";

class RunFormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Direction { ccw = 1, cw = -1 };

// One DBB run in SI units.
struct Run {
  std::string source;  // file name (for messages)
  double radius_m = 0.0;
  double height_m = 0.0;
  Direction direction = Direction::ccw;
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
Run parse_run(const std::string& text, const std::string& source);
Run read_run(const std::string& path);

// Checks a run built in memory (the same checks as parse_run); throws RunFormatError.
void validate_run(const Run& run);

// Writes a run (angle in degrees, dL in um) with its metadata; extra metadata lines are kept.
std::string format_run(const Run& run);
void write_run(const Run& run, const std::string& path);

}  // namespace guideway::models::dbb
